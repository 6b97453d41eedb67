// Distributed decoding of a .vcz under MPI: every rank decodes only the bricks of its slab (the ParaView
// reader's parallel path without ParaView); counts bricks, times I/O and decoding, optionally checks the
// gathered volume against a 1-rank decode.
#include "plugins/paraview/VczPieces.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "wavelet/Codec.hpp"

// OpenMPI's C++ bindings (deprecated, and not linked here) stay out; the C API is used.
#define OMPI_SKIP_MPICXX 1
#include <mpi.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using namespace volcl;

// A smooth field with a ball and hashed noise (the test volume `make` writes); the ball moves along x with
// `frame` (the frames of a generated series).
Volume generatedField(Dims d, std::size_t frame = 0) {
    Volume v(d, ScalarType::UInt16);
    auto vals = v.values<std::uint16_t>();
    for (std::size_t k = 0; k < d.z; ++k)
        for (std::size_t j = 0; j < d.y; ++j)
            for (std::size_t i = 0; i < d.x; ++i) {
                std::uint32_t hsh = std::uint32_t(i * 73856093u ^ j * 19349663u ^ k * 83492791u);
                hsh ^= hsh >> 13, hsh *= 0x5bd1e995u, hsh ^= hsh >> 15;
                const double r = std::hypot(double(i) - (0.5 - 0.15 * double(frame)) * double(d.x),
                                            double(j) - 0.4 * double(d.y), double(k) - 0.6 * double(d.z));
                const double f = 0.5 + 0.3 * std::sin(0.09 * double(i)) * std::cos(0.07 * double(j)) +
                                 (r < 0.25 * double(d.x) ? 0.15 : 0.0);
                vals[v.index(i, j, k)] = std::uint16_t(f * 50000 + double(hsh & 0x3f));
            }
    return v;
}

int run(int argc, char** argv, int rank, int size) {
    const std::string usage =
        "usage: vcz-mpi-decode make OUT.vcz [NX NY NZ [FRAMES]] | mpiexec -n N vcz-mpi-decode "
        "FILE.vcz [--level L] [--frame F] [--check]";
    if (argc < 2) throw UsageError(usage);
    if (std::string(argv[1]) == "make") {
        if (argc != 3 && argc != 6 && argc != 7) throw UsageError(usage);
        const Dims d = argc >= 6 ? Dims{std::stoul(argv[3]), std::stoul(argv[4]), std::stoul(argv[5])}
                                 : Dims{96, 80, 128};
        const std::size_t frames = argc == 7 ? std::stoul(argv[6]) : 1;
        if (frames < 1) throw UsageError(usage);
        ComputeContext cc;
        CodecOptions o;
        o.brick = {32, 32, 32};
        o.levels = 2;
        // A series is I frames only (frame f at time 10 f): each frame's region decodes only its own bricks.
        o.motion = MotionMode::None;
        TimeSeries series;
        for (std::size_t f = 0; f < frames; ++f) {
            series.frames.push_back(generatedField(d, f));
            series.times.push_back(10.0 * double(f));
        }
        const auto vcz = frames == 1 ? encodeVolume(cc, series.frames[0], o) : encodeSeries(cc, series, o);
        AtomicFile out(argv[2]);
        out.write(vcz);
        out.commit();
        return 0;
    }
    const std::string path = argv[1];
    int level = 0;
    std::size_t frame = 0;
    bool check = false;
    for (int i = 2; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--check")
            check = true;
        else if (a == "--level" && i + 1 < argc)
            level = std::stoi(argv[++i]);
        else if (a == "--frame" && i + 1 < argc)
            frame = std::stoul(argv[++i]);
        else
            throw UsageError(usage);
    }
    ComputeContext cc;
    { // kernels built outside the timings: decode one brick of a tiny generated volume
        CodecOptions o;
        o.brick = {16, 16, 16};
        o.levels = 2;
        const auto warm = encodeVolume(cc, generatedField({16, 16, 16}), o);
        decodeVolume(cc, warm, {.level = level});
    }
    MPI_Barrier(MPI_COMM_WORLD);
    const double t0 = MPI_Wtime();
    const VczReader reader(readFileBytes(path), path);
    const double t1 = MPI_Wtime();
    const pieces::Extent e = pieces::pieceExtent(reader.header(), level, rank, size);
    std::size_t bricks = 0;
    Volume mine;
    if (!e.empty()) {
        DecodeOptions o;
        o.region = pieces::regionOf(reader.header(), level, e);
        o.level = level;
        o.frame = frame;
        o.threads = 1;
        bricks = pieces::bricksOf(reader.header(), *o.region).size();
        mine = reader.decode(cc, o);
    }
    const double t2 = MPI_Wtime();
    const double io = t1 - t0, decode = t2 - t1;
    unsigned long long myBricks = bricks, allBricks = 0;
    double slowest = 0, slowestIo = 0, slowestDecode = 0;
    const double total = t2 - t0;
    MPI_Reduce(&myBricks, &allBricks, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, 0, MPI_COMM_WORLD);
    MPI_Reduce(&total, &slowest, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    MPI_Reduce(&io, &slowestIo, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    MPI_Reduce(&decode, &slowestDecode, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    for (int r = 0; r < size; ++r) {
        if (r == rank)
            std::printf("rank %d extent z [%zu, %zu) bricks %zu of %zu read_ms %.1f decode_ms %.1f\n", rank,
                        e.lo.z, e.hi.z, bricks, reader.header().brickCount(), 1e3 * io, 1e3 * decode);
        std::fflush(stdout);
        MPI_Barrier(MPI_COMM_WORLD);
    }
    const Dims ld = pieces::levelDims(reader.header(), level);
    const double mb = double(ld.count() * scalarSize(reader.header().type)) / 1e6;
    if (rank == 0)
        std::printf(
            "decode ranks=%d level=%d dims=%zux%zux%zu out_MB=%.2f file_MB=%.2f bricks=%llu seconds=%.3f "
            "read_s=%.4f decode_s=%.3f MB/s=%.1f ms/brick=%.2f\n",
            size, level, ld.x, ld.y, ld.z, mb, double(reader.fileSize()) / 1e6, allBricks, slowest, slowestIo,
            slowestDecode, mb / slowest, allBricks ? 1e3 * slowestDecode * size / double(allBricks) : 0.0);

    int ok = 1;
    if (check) { // gather the slabs on rank 0 (z slabs are contiguous in x-fastest order) and compare
        if (mine.byteSize() > std::size_t(std::numeric_limits<int>::max()))
            throw UsageError("--check gathers at most 2 GiB per rank");
        const int bytes = int(mine.byteSize());
        std::vector<int> counts(size), offsets(size);
        MPI_Gather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
        for (int r = 1; r < size; ++r)
            offsets[r] = offsets[r - 1] + counts[r - 1];
        std::vector<std::byte> whole(rank == 0 ? ld.count() * scalarSize(reader.header().type) : 0);
        MPI_Gatherv(mine.bytes().data(), bytes, MPI_BYTE, whole.data(), counts.data(), offsets.data(),
                    MPI_BYTE, 0, MPI_COMM_WORLD);
        if (rank == 0) {
            const Volume reference = reader.decode(cc, {.level = level, .frame = frame});
            ok = reference.byteSize() == whole.size() &&
                 std::memcmp(reference.bytes().data(), whole.data(), whole.size()) == 0 &&
                 allBricks == pieces::bricksOf(reader.header(), {{0, 0, 0}, reader.header().dims}).size();
            std::printf("check: %d-rank slabs %s the 1-rank decode; bricks decoded %llu (each once: %s)\n",
                        size, ok ? "equal" : "DIFFER from", allBricks, ok ? "yes" : "no");
        }
        MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
    }
    return ok ? 0 : 1;
}

} // namespace

int main(int argc, char** argv) {
    MPI_Init(&argc, &argv);
    int rank = 0, size = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    int rc = 0;
    try {
        rc = run(argc, argv, rank, size);
    } catch (const UsageError& e) {
        if (rank == 0) std::fprintf(stderr, "vcz-mpi-decode: %s\n", e.what());
        rc = 2;
    } catch (const std::logic_error&) { // std::stoi / std::stoul on a malformed number
        if (rank == 0) std::fprintf(stderr, "vcz-mpi-decode: malformed number in the arguments\n");
        rc = 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "vcz-mpi-decode: %s\n", e.what());
        rc = 1;
    }
    MPI_Finalize();
    return rc;
}
