// The peers of `volcl bench codec` on the same voxels: zfp (reversible and fixed accuracy), zstd and xz -9.
#include "apps/bench/CodecPeers.hpp"

#include "core/Error.hpp"
#include "core/runtime/Timing.hpp"
#include "wavelet/Metrics.hpp"

#include <zfp.h>
#include <zstd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

namespace volcl::cli {

namespace fs = std::filesystem;

namespace {

// PSNR of a float decode against the volume, with integer data rounded and clamped like a real decoder.
double psnrAsType(const Volume& v, const Volume& decodedFloat) {
    return psnr(v, decodedFloat.convertedTo(v.type()));
}

} // namespace

ZfpResult runZfp(const Volume& v, std::optional<double> tolerance, int runs) {
    const Dims d = v.dims();
    const bool reversible = !tolerance;
    std::vector<std::int32_t> ints;
    std::vector<float> floats;
    if (reversible && !isFloatType(v.type())) {
        ints.resize(v.voxelCount());
        for (std::size_t i = 0; i < ints.size(); ++i)
            ints[i] = static_cast<std::int32_t>(v.valueAt(i));
    } else {
        floats = v.toFloat();
    }
    void* data = ints.empty() ? static_cast<void*>(floats.data()) : static_cast<void*>(ints.data());
    const zfp_type type = ints.empty() ? zfp_type_float : zfp_type_int32;
    zfp_field* field = zfp_field_3d(data, type, d.x, d.y, d.z);
    zfp_stream* zs = zfp_stream_open(nullptr);
    if (reversible)
        zfp_stream_set_reversible(zs);
    else
        zfp_stream_set_accuracy(zs, *tolerance);
    std::vector<unsigned char> buffer(zfp_stream_maximum_size(zs, field));
    bitstream* bs = stream_open(buffer.data(), buffer.size());
    zfp_stream_set_bit_stream(zs, bs);
    ZfpResult r;
    r.tolerance = tolerance.value_or(0.0);
    const bool omp = zfp_stream_set_execution(zs, zfp_exec_omp);
    r.encodeMs = medianMilliseconds(runs, [&] {
        zfp_stream_rewind(zs);
        r.bytes = zfp_compress(zs, field);
    });
    if (omp) zfp_stream_set_execution(zs, zfp_exec_serial); // zfp 1.0 decompresses serially
    std::vector<std::int32_t> outInts(ints.size());
    std::vector<float> outFloats(floats.size());
    zfp_field* outField =
        zfp_field_3d(ints.empty() ? static_cast<void*>(outFloats.data()) : static_cast<void*>(outInts.data()),
                     type, d.x, d.y, d.z);
    r.decodeMs = medianMilliseconds(runs, [&] {
        zfp_stream_rewind(zs);
        zfp_decompress(zs, outField);
    });
    zfp_field_free(outField);
    zfp_field_free(field);
    zfp_stream_close(zs);
    stream_close(bs);
    if (r.bytes == 0) throw Error("zfp compression failed");
    Volume out(d, ScalarType::Float32);
    auto o = out.values<float>();
    for (std::size_t i = 0; i < o.size(); ++i)
        o[i] = ints.empty() ? outFloats[i] : static_cast<float>(outInts[i]);
    r.decoded = std::move(out);
    return r;
}

// zfp accuracy tolerance that reaches `target` dB (bisection on log tolerance; largest tolerance meeting it).
ZfpResult zfpAtPsnr(const Volume& v, double target, int runs) {
    const VolumeStats st = v.stats(1);
    const double range = std::max(st.max - st.min, 1e-30);
    double lo = std::log2(range) - 40, hi = std::log2(range);
    double best = lo;
    for (int it = 0; it < 18; ++it) {
        const double mid = 0.5 * (lo + hi);
        ZfpResult r = runZfp(v, std::exp2(mid), 0);
        if (psnrAsType(v, r.decoded) >= target) {
            best = mid;
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return runZfp(v, std::exp2(best), runs);
}

std::size_t zstdSize(const Volume& v, int level, double& ms, double& decMs, int runs) {
    std::vector<char> out(ZSTD_compressBound(v.byteSize()));
    std::size_t n = 0;
    ms = medianMilliseconds(
        runs, [&] { n = ZSTD_compress(out.data(), out.size(), v.bytes().data(), v.byteSize(), level); });
    if (ZSTD_isError(n)) throw Error("zstd failed");
    std::vector<char> back(v.byteSize());
    decMs = medianMilliseconds(runs, [&] { ZSTD_decompress(back.data(), back.size(), out.data(), n); });
    return n;
}

// xz -9 through the xz binary (the general-purpose reference ratio); one run, single-threaded.
std::size_t xzSize(const Volume& v, const fs::path& tmpDir, double& ms) {
    const fs::path in = tmpDir / "volcl-bench-xz.raw";
    {
        std::ofstream f(in, std::ios::binary);
        f.write(reinterpret_cast<const char*>(v.bytes().data()), static_cast<std::streamsize>(v.byteSize()));
    }
    const std::size_t n = compressedFileSize("xz -9 -T1", in, ms);
    fs::remove(in);
    return n;
}

std::size_t compressedFileSize(const std::string& compressor, const fs::path& file, double& ms) {
    Stopwatch sw;
    const std::string cmd = compressor + " -c '" + file.string() + "' | wc -c";
    FILE* p = popen(cmd.c_str(), "r");
    std::size_t n = 0;
    if (p) {
        if (std::fscanf(p, "%zu", &n) != 1) n = 0;
        pclose(p);
    }
    ms = sw.milliseconds();
    return n;
}

} // namespace volcl::cli
