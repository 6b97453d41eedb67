// Benchmark of the HDF5 filter: per-chunk encode/decode cost by chunk size, and HDF5 write/read through
// volcl against deflate (HDF5's built-in gzip) and no filter, measured in the same run.
#include "plugins/hdf5/ChunkCodec.hpp"
#include "plugins/hdf5/H5Zvolcl.h"

#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "host/io/VolumeIo.hpp"
#include "wavelet/Codec.hpp"

#include <hdf5.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <string>
#include <vector>

namespace {

using namespace volcl;
using Clock = std::chrono::steady_clock;

double seconds(Clock::time_point a) {
    return std::chrono::duration<double>(Clock::now() - a).count();
}
double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

// The chunks of edge c that fit whole inside the volume, as the filter receives them (z, y, x order).
std::vector<std::vector<std::byte>> cutChunks(const Volume& v, std::size_t c) {
    const std::size_t es = scalarSize(v.type());
    std::vector<std::vector<std::byte>> chunks;
    const Dims d = v.dims();
    for (std::size_t z = 0; z + c <= d.z; z += c)
        for (std::size_t y = 0; y + c <= d.y; y += c)
            for (std::size_t x = 0; x + c <= d.x; x += c) {
                std::vector<std::byte> b(c * c * c * es);
                for (std::size_t k = 0; k < c; ++k)
                    for (std::size_t j = 0; j < c; ++j)
                        std::memcpy(b.data() + ((k * c + j) * c) * es,
                                    v.bytes().data() + v.index(x, y + j, z + k) * es, c * es);
                chunks.push_back(std::move(b));
            }
    return chunks;
}

hid_t fileType(ScalarType t) {
    switch (t) {
    case ScalarType::UInt8:
        return H5T_STD_U8LE;
    case ScalarType::UInt16:
        return H5T_STD_U16LE;
    case ScalarType::Int16:
        return H5T_STD_I16LE;
    case ScalarType::Float32:
        return H5T_IEEE_F32LE;
    }
    return -1;
}

// Writes then reads the volume as one chunked dataset; returns {write s, read s, stored bytes}.
std::array<double, 3> hdf5RoundTrip(const Volume& v, const std::string& path, std::size_t c,
                                    const std::function<herr_t(hid_t)>& filter) {
    const Dims d = v.dims();
    const hsize_t dims[3] = {d.z, d.y, d.x},
                  chunk[3] = {std::min(c, d.z), std::min(c, d.y), std::min(c, d.x)};
    auto t0 = Clock::now();
    hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    hid_t s = H5Screate_simple(3, dims, nullptr);
    hid_t dcpl = H5Pcreate(H5P_DATASET_CREATE);
    H5Pset_chunk(dcpl, 3, chunk);
    if (filter && filter(dcpl) < 0) throw UsageError("filter setup failed");
    hid_t ds = H5Dcreate2(f, "v", fileType(v.type()), s, H5P_DEFAULT, dcpl, H5P_DEFAULT);
    if (ds < 0 || H5Dwrite(ds, fileType(v.type()), H5S_ALL, H5S_ALL, H5P_DEFAULT, v.bytes().data()) < 0)
        throw IoError(path + ": HDF5 write failed");
    H5Dclose(ds);
    H5Pclose(dcpl);
    H5Sclose(s);
    H5Fclose(f);
    const double write = seconds(t0);
    std::vector<std::byte> back(v.byteSize());
    t0 = Clock::now();
    f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    ds = H5Dopen2(f, "v", H5P_DEFAULT);
    if (H5Dread(ds, fileType(v.type()), H5S_ALL, H5S_ALL, H5P_DEFAULT, back.data()) < 0)
        throw IoError(path + ": HDF5 read failed");
    const double stored = double(H5Dget_storage_size(ds));
    H5Dclose(ds);
    H5Fclose(f);
    const double read = seconds(t0);
    if (filter && !std::equal(back.begin(), back.end(), v.bytes().begin()) &&
        path.find("lossless") != std::string::npos)
        throw DataError(path + ": lossless round trip differs");
    return {write, read, stored};
}

} // namespace

int main(int argc, char** argv) try {
    if (argc < 3) {
        std::cerr << "usage: h5z-volcl-bench VOLUME WORK_DIR [REPS]   (REPS interleaved runs, medians)\n";
        return 2;
    }
    const Volume v = readVolume(argv[1]);
    const std::filesystem::path work = argv[2];
    const int reps = argc > 3 ? std::max(1, std::atoi(argv[3])) : 3;
    std::filesystem::create_directories(work);
    H5PLprepend(VOLCL_HDF5_PLUGIN_DIR);
    ComputeContext cc;
    const double mb = double(v.byteSize()) / 1e6;
    std::printf("# volume %s %zux%zux%zu %s (%.2f MB), device %s, %d interleaved reps, medians\n", argv[1],
                v.dims().x, v.dims().y, v.dims().z, std::string(scalarTypeName(v.type())).c_str(), mb,
                cc.device().name.c_str(), reps);

    // Per-chunk cost of the filter's work (no HDF5): encode and decode every whole chunk of edge c.
    std::printf(
        "part,chunk_edge,chunks,encode_ms_per_chunk,decode_ms_per_chunk,encode_MBps,decode_MBps,ratio\n");
    for (std::size_t c : {8, 16, 32, 64}) {
        const auto chunks = cutChunks(v, c);
        if (chunks.empty()) continue;
        hdf5::FilterParameters p;
        p.type = v.type();
        p.chunk = {c, c, c, 0};
        std::vector<std::vector<std::byte>> stored(chunks.size());
        std::vector<std::byte> out(p.chunkBytes());
        hdf5::encodeChunk(cc, p, chunks[0]); // kernel builds outside the timings
        std::vector<double> enc, dec;
        double bytesIn = 0, bytesOut = 0;
        for (int r = 0; r < reps; ++r) {
            auto t0 = Clock::now();
            for (std::size_t i = 0; i < chunks.size(); ++i)
                stored[i] = hdf5::encodeChunk(cc, p, chunks[i]);
            enc.push_back(seconds(t0));
            t0 = Clock::now();
            for (std::size_t i = 0; i < chunks.size(); ++i)
                hdf5::decodeChunk(cc, p, stored[i], out);
            dec.push_back(seconds(t0));
        }
        for (std::size_t i = 0; i < chunks.size(); ++i)
            bytesIn += double(chunks[i].size()), bytesOut += double(stored[i].size());
        std::printf("chunk,%zu,%zu,%.3f,%.3f,%.1f,%.1f,%.2f\n", c, chunks.size(),
                    1e3 * median(enc) / double(chunks.size()), 1e3 * median(dec) / double(chunks.size()),
                    bytesIn / 1e6 / median(enc), bytesIn / 1e6 / median(dec), bytesIn / bytesOut);
    }
    // Peer in the same run: the codec on the whole volume in one call (64^3 bricks).
    {
        CodecOptions o;
        o.threads = 1;
        std::vector<double> enc, dec;
        std::vector<std::byte> vcz;
        for (int r = 0; r < reps; ++r) {
            auto t0 = Clock::now();
            vcz = encodeVolume(cc, v, o);
            enc.push_back(seconds(t0));
            t0 = Clock::now();
            DecodeOptions d;
            d.threads = 1;
            const Volume back = decodeVolume(cc, vcz, d);
            dec.push_back(seconds(t0));
        }
        std::printf("whole,volume,1,%.3f,%.3f,%.1f,%.1f,%.2f\n", 1e3 * median(enc), 1e3 * median(dec),
                    mb / median(enc), mb / median(dec), double(v.byteSize()) / double(vcz.size()));
    }

    // HDF5 datasets, interleaved per rep: none, deflate 1, deflate 6, volcl lossless, volcl max-error.
    struct Method {
        const char* name;
        std::function<herr_t(hid_t)> filter;
    };
    const double range = v.stats().max - v.stats().min;
    const double maxError = std::max(1.0, 0.005 * range);
    const std::vector<Method> methods = {
        {"none", [](hid_t) { return herr_t(0); }},
        {"deflate1", [](hid_t dcpl) { return H5Pset_deflate(dcpl, 1); }},
        {"deflate6", [](hid_t dcpl) { return H5Pset_deflate(dcpl, 6); }},
        {"volcl-lossless", [](hid_t dcpl) { return H5Pset_volcl_lossless(dcpl); }},
        {"volcl-maxerr", [maxError](hid_t dcpl) { return H5Pset_volcl_max_error(dcpl, maxError); }},
    };
    std::printf("part,chunk_edge,method,write_MBps,read_MBps,ratio\n");
    for (std::size_t c : {32, 64}) {
        std::vector<std::vector<double>> w(methods.size()), rd(methods.size());
        std::vector<double> stored(methods.size());
        for (int r = 0; r < reps + 1; ++r)
            for (std::size_t m = 0; m < methods.size(); ++m) {
                const auto t = hdf5RoundTrip(v, (work / (std::string(methods[m].name) + ".h5")).string(), c,
                                             methods[m].filter);
                if (r == 0) continue; // first pass: file system and kernel caches warm
                w[m].push_back(t[0]);
                rd[m].push_back(t[1]);
                stored[m] = t[2];
            }
        for (std::size_t m = 0; m < methods.size(); ++m)
            std::printf("hdf5,%zu,%s,%.1f,%.1f,%.2f\n", c, methods[m].name, mb / median(w[m]),
                        mb / median(rd[m]), double(v.byteSize()) / stored[m]);
    }
    std::printf("# volcl-maxerr bound %.3g (0.5%% of the value range, at least 1)\n", maxError);
    return 0;
} catch (const std::exception& e) {
    std::cerr << "h5z-volcl-bench: " << e.what() << "\n";
    return 1;
}
