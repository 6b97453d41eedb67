// Entropy-only speed of the dense (default) or fast (--fast) coder on real codec coefficients: one thread,
// CPU time, median of 5. Reads the coefficients of each .vcz file given (entropy decoded with the file's own
// mode), then times encode and decode of every section and checks the round trip; with --fast, lossy files
// decode through decodeSections with dequantisation, as the codec does. Timings live here, not in tests.
// When the SIMD dense coder is selected, each brick is also encoded and decoded with the scalar one (the
// encoders must write the same bytes; VOLCL_DENSE_SCALAR=1 measures the scalar ones alone,
// VOLCL_BENCH_SIMD_ONLY=1 the SIMD ones alone, e.g. for a profile; VOLCL_BENCH_ENCODE_ONLY=1 skips the timed
// decodes, for profiles and counters of the encoder). Dense mode also codes every section with the
// set-partitioning coder in the same runs and prints its bytes and speed beside the dense coder's.
#include "core/Error.hpp"
#include "wavelet/container/VczFormat.hpp"
#include "wavelet/entropy/EntropyCoder.hpp"
#include "wavelet/entropy/SpeckModel.hpp"
#include "wavelet/entropy/TestSwitches.hpp"
#include "wavelet/payload/BrickPayload.hpp"
#include "wavelet/payload/VoxelBrick.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <exception>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

using namespace volcl;

namespace {

// Coefficient bricks of a .vcz file, entropy decoded with the file's own mode.
struct CodedVolume {
    std::vector<Dims> dims;
    std::vector<std::vector<std::int32_t>> coeffs;
    int levels = 0;
    std::size_t voxelBytes = 0;
    bool lossy = false;
    std::vector<double> steps;
    double bias = 0.5;
};

CodedVolume readCoefficients(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    const std::vector<char> chars((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    std::vector<std::byte> file(chars.size());
    std::memcpy(file.data(), chars.data(), chars.size());
    const VczHeader h = readVczHeader(file, path);
    CodedVolume v;
    v.levels = h.levels;
    v.voxelBytes = scalarSize(h.type);
    v.lossy = h.transform == TransformKind::FloatLifting;
    v.steps = h.steps;
    v.bias = h.reconstructionBias;
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        const auto p = vczBrickPayload(file, h, 0, b, path);
        if (codec::isVoxelBrick(p)) continue; // coded as voxels: no coefficients
        const Dims d = h.brickDims(b);
        const auto layout = sectionLayout(d, h.levels);
        const codec::ParsedPayload parsed = codec::parsePayload(p, layout.size(), path);
        std::vector<std::int32_t> c(d.count());
        decodeSections(parsed.sections, c, d, layout, h.entropy, path.c_str(), nullptr,
                       parsed.setPartitioned);
        v.dims.push_back(d);
        v.coeffs.push_back(std::move(c));
    }
    return v;
}

double threadSeconds() {
    timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

} // namespace

int main(int argc, char** argv) try {
    const bool fast = argc > 1 && std::string(argv[1]) == "--fast";
    const EntropyMode mode = fast ? EntropyMode::Fast : EntropyMode::Dense;
    if (argc < 2 + int(fast)) {
        std::fprintf(
            stderr,
            "usage: %s [--fast] FILE.vcz...  (make inputs with e.g. volcl encode IN -o X.vcz --entropy "
            "fast, lossless or --psnr 50)\n",
            argv[0]);
        return 2;
    }
    const bool forcedScalar = denseDecoderIsScalar(), encoderForcedScalar = denseEncoderIsScalar();
    const bool compare = !fast && !forcedScalar && !std::getenv("VOLCL_BENCH_SIMD_ONLY");
    const bool encodeOnly = std::getenv("VOLCL_BENCH_ENCODE_ONLY") != nullptr;
    for (int arg = 1 + int(fast); arg < argc; ++arg) {
        const std::string path = argv[arg];
        const CodedVolume v = readCoefficients(path);
        std::size_t n = 0;
        for (const auto& c : v.coeffs)
            n += c.size();
        std::vector<std::vector<std::vector<std::uint8_t>>> coded(v.coeffs.size());
        std::vector<double> enc, dec, decScalar, ratio, encScalar, encRatio, speckEnc, speckDec;
        std::size_t speckBytes = 0;
        // Reference output: the coefficients, dequantised when the decoder dequantises.
        const Dequantiser dq{v.steps, v.bias};
        const Dequantiser* dqp = fast && v.lossy ? &dq : nullptr;
        std::vector<std::vector<std::int32_t>> ref = v.coeffs, out(v.coeffs.size());
        for (std::size_t b = 0; b < v.coeffs.size() && dqp; ++b)
            for (const auto& sec : sectionLayout(v.dims[b], v.levels))
                for (const SubbandBox& x : sec)
                    for (std::size_t z = x.z0; z < x.z1; ++z)
                        for (std::size_t y = x.y0; y < x.y1; ++y) {
                            std::int32_t* r = ref[b].data() + (z * v.dims[b].y + y) * v.dims[b].x + x.x0;
                            dequantiseRow(r, reinterpret_cast<float*>(r), x.x1 - x.x0, dq.step(x), dq.bias);
                        }
        for (int rep = 0; rep < 5; ++rep) {
            // Encoders alternate per brick like the decoders below.
            double t0 = 0, eSimd = 0, eScalar = 0;
            for (std::size_t b = 0; b < v.coeffs.size(); ++b) {
                const auto layout = sectionLayout(v.dims[b], v.levels);
                std::vector<std::vector<std::uint8_t>> other;
                for (int k = 0; k < (compare ? 2 : 1); ++k) {
                    const bool scalar =
                        encoderForcedScalar || (compare && ((b + static_cast<std::size_t>(k)) & 1) != 0);
                    setDenseEncoderScalar(scalar);
                    auto& dst = k == 0 ? coded[b] : other;
                    dst.assign(layout.size(), {});
                    t0 = threadSeconds();
                    for (std::size_t s = 0; s < layout.size(); ++s)
                        encodeSection(v.coeffs[b], v.dims[b], layout, s, mode, dst[s]);
                    (scalar && compare ? eScalar : eSimd) += threadSeconds() - t0;
                }
                if (compare && other != coded[b])
                    throw Error(path + ": scalar and SIMD encoders differ in brick " + std::to_string(b));
            }
            setDenseEncoderScalar(encoderForcedScalar);
            enc.push_back(eSimd);
            if (compare) encScalar.push_back(eScalar);
            if (compare) encRatio.push_back(eScalar / eSimd);
            // Only the decoding is timed (the codec decodes into a batch slot that it does not clear). With
            // the SIMD dense decoder selected, each brick is decoded by both decoders in turn (the first one
            // alternating): the machine is shared, and load changes over a run would bias whole-run pairs.
            double tSimd = 0, tScalar = 0;
            for (std::size_t b = 0; b < v.coeffs.size() && !encodeOnly; ++b) {
                const auto layout = sectionLayout(v.dims[b], v.levels);
                const std::vector<std::span<const std::uint8_t>> spans(coded[b].begin(), coded[b].end());
                for (int k = 0; k < (compare ? 2 : 1); ++k) {
                    const bool scalar =
                        forcedScalar || (compare && ((b + static_cast<std::size_t>(k)) & 1) != 0);
                    setDenseDecoderScalar(scalar);
                    out[b].assign(v.coeffs[b].size(), 0);
                    t0 = threadSeconds();
                    decodeSections(spans, out[b], v.dims[b], layout, mode, "bench", dqp);
                    (scalar && compare ? tScalar : tSimd) += threadSeconds() - t0;
                    if (out[b] != ref[b])
                        throw Error(path + ": round trip differs in brick " + std::to_string(b));
                }
            }
            setDenseDecoderScalar(forcedScalar);
            // The set-partitioning coder on every section of the same bricks, in the same run (dense mode).
            double sEnc = 0, sDec = 0;
            speckBytes = 0;
            for (std::size_t b = 0; b < v.coeffs.size() && !fast && !encodeOnly; ++b) {
                const auto layout = sectionLayout(v.dims[b], v.levels);
                std::vector<std::vector<std::uint8_t>> sp(layout.size());
                t0 = threadSeconds();
                for (std::size_t s = 0; s < layout.size(); ++s)
                    if (!layout[s].empty()) entropy::encodeSpeck(v.coeffs[b], v.dims[b], layout[s], sp[s]);
                sEnc += threadSeconds() - t0;
                std::vector<std::int32_t> back(v.coeffs[b].size(), 0);
                t0 = threadSeconds();
                for (std::size_t s = 0; s < layout.size(); ++s)
                    if (!layout[s].empty())
                        decodeSection(sp[s], back, v.dims[b], layout, s, mode, "bench", true);
                sDec += threadSeconds() - t0;
                if (back != v.coeffs[b])
                    throw Error(path + ": set-partitioning round trip differs in brick " + std::to_string(b));
                for (const auto& x : sp)
                    speckBytes += x.size();
            }
            speckEnc.push_back(sEnc);
            speckDec.push_back(sDec);
            dec.push_back(tSimd);
            if (compare) decScalar.push_back(tScalar);
            if (compare) ratio.push_back(decScalar.back() / dec.back());
        }
        std::size_t bytes = 0; // sections plus the codec's per-brick payload header
        for (const auto& brick : coded) {
            bytes += 2 + 4 * (brick.size() + 1);
            for (const auto& s : brick)
                bytes += s.size();
        }
        std::sort(enc.begin(), enc.end());
        std::sort(dec.begin(), dec.end());
        // On a shared machine the best run is the steadier guide to a code change; the median is printed too.
        if (encodeOnly)
            std::printf("%s: %zu coefficients, %zu bytes (ratio %.4f), %s encode %.1f Mcoef/s (best %.1f), "
                        "decoding skipped\n",
                        path.c_str(), n, bytes, double(n * v.voxelBytes) / double(bytes),
                        fast ? "fast" : "dense", double(n) / enc[2] / 1e6, double(n) / enc[0] / 1e6);
        else
            std::printf("%s: %zu coefficients, %zu bytes (ratio %.4f), %s encode %.1f / decode %.1f Mcoef/s "
                        "(best %.1f / %.1f)\n",
                        path.c_str(), n, bytes, double(n * v.voxelBytes) / double(bytes),
                        fast ? "fast" : "dense", double(n) / enc[2] / 1e6, double(n) / dec[2] / 1e6,
                        double(n) / enc[0] / 1e6, double(n) / dec[0] / 1e6);
        if (!fast && !encodeOnly) {
            std::size_t denseBytes = 0;
            for (const auto& brick : coded)
                for (const auto& x : brick)
                    denseBytes += x.size();
            std::sort(speckEnc.begin(), speckEnc.end());
            std::sort(speckDec.begin(), speckDec.end());
            std::printf(
                "  set partitioning on every section: %zu section bytes (dense %zu, %.3fx), encode %.1f / "
                "decode %.1f Mcoef/s (best %.1f / %.1f)\n",
                speckBytes, denseBytes, double(speckBytes) / double(denseBytes),
                double(n) / speckEnc[2] / 1e6, double(n) / speckDec[2] / 1e6, double(n) / speckEnc[0] / 1e6,
                double(n) / speckDec[0] / 1e6);
        }
        if (compare) {
            std::sort(encScalar.begin(), encScalar.end());
            std::sort(encRatio.begin(), encRatio.end());
            std::printf(
                "  scalar encoder alternating: %.1f Mcoef/s (best %.1f); SIMD speed-up per pair: median "
                "%.2fx (%.2f-%.2f)\n",
                double(n) / encScalar[2] / 1e6, double(n) / encScalar[0] / 1e6, encRatio[2], encRatio[0],
                encRatio[4]);
        }
        if (compare && !encodeOnly) {
            std::sort(decScalar.begin(), decScalar.end());
            std::sort(ratio.begin(), ratio.end());
            std::printf(
                "  scalar decoder alternating: %.1f Mcoef/s (best %.1f); SIMD speed-up per pair: median "
                "%.2fx (%.2f-%.2f)\n",
                double(n) / decScalar[2] / 1e6, double(n) / decScalar[0] / 1e6, ratio[2], ratio[0], ratio[4]);
        }
    }
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "volcl-bench-entropy: %s\n", e.what());
    return 1;
}
