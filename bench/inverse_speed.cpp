// Inverse-transform-only speed on real codec coefficients: the batched brick inverse of one .vcz file.
// The bricks are entropy decoded (and dequantised, for lossy files) into batches of one brick shape each,
// as the decoder does, then the inverse of all batches (one launch on CPUs) is timed `runs` times, the input
// restored before each run. The spread the codec shows is between processes, so run this in many fresh
// processes (bench/inverse_spread.sh); timings live here, not in tests.
#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/Timing.hpp"
#include "wavelet/container/VczFormat.hpp"
#include "wavelet/entropy/EntropyCoder.hpp"
#include "wavelet/payload/BrickPayload.hpp"
#include "wavelet/transform/LiftingTransform.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include <dirent.h>
#include <sys/prctl.h>
#include <sys/resource.h>

using namespace volcl;

namespace {

std::vector<std::byte> readFile(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f) throw IoError(path + ": cannot open");
    const std::vector<char> chars((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    std::vector<std::byte> file(chars.size());
    std::memcpy(file.data(), chars.data(), chars.size());
    return file;
}

// One brick's coefficients entropy decoded into rows of `pitch` (lossy: dequantised float bit patterns).
void decodeBrick(std::span<const std::byte> file, const VczHeader& h, std::size_t b, std::int32_t* dst,
                 std::size_t pitch, const std::string& path) {
    const auto p = vczBrickPayload(file, h, 0, b, path);
    const Dims d = h.brickDims(b), storage{pitch, d.y, d.z};
    const auto layout = sectionLayout(d, h.levels);
    const codec::ParsedPayload parsed = codec::parsePayload(p, layout.size(), path);
    const Dequantiser dq{h.steps, h.reconstructionBias};
    decodeSections(parsed.sections, std::span<std::int32_t>(dst, storage.count()), storage, layout, h.entropy,
                   path.c_str(), h.transform == TransformKind::FloatLifting ? &dq : nullptr,
                   parsed.setPartitioned);
}

// CPU time of the whole process (the device's worker threads included), in milliseconds.
double processCpuMs() {
    rusage u;
    getrusage(RUSAGE_SELF, &u);
    return (double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) * 1e3 +
            double(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-3);
}

// Run time in ms of each thread of this process (/proc/self/task/*/schedstat), to see how the device's
// worker threads share the work.
std::vector<std::pair<int, double>> threadRunMs() {
    std::vector<std::pair<int, double>> out;
    if (DIR* d = opendir("/proc/self/task")) {
        while (dirent* e = readdir(d)) {
            if (e->d_name[0] == '.') continue;
            std::ifstream f(std::string("/proc/self/task/") + e->d_name + "/schedstat");
            double ns = 0;
            f >> ns;
            out.emplace_back(std::atoi(e->d_name), ns * 1e-6);
        }
        closedir(d);
    }
    std::sort(out.begin(), out.end());
    return out;
}

bool freshTransform = false; // a new LiftingTransform per run, as each codec decode makes one

// AnonHugePages of this process in kB (/proc/self/smaps_rollup).
long anonHugeKb() {
    std::ifstream f("/proc/self/smaps_rollup");
    std::string key;
    long kb = 0;
    while (f >> key) {
        if (key == "AnonHugePages:") {
            f >> kb;
            break;
        }
    }
    return kb;
}

template <class T> int run(const std::string& path, int runs, bool zero) {
    const std::vector<std::byte> file = readFile(path);
    const VczHeader h = readVczHeader(file, path);
    ComputeContext cc;
    LiftingTransform<T> t(cc, h.wavelet);
    // One batch per brick shape, in first-seen order (as the codec groups them).
    std::vector<Dims> shapes;
    std::vector<std::vector<std::size_t>> members;
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        const Dims d = h.brickDims(b);
        auto it = std::find(shapes.begin(), shapes.end(), d);
        if (it == shapes.end()) {
            shapes.push_back(d);
            members.emplace_back();
            it = shapes.end() - 1;
        }
        members[std::size_t(it - shapes.begin())].push_back(b);
    }
    std::vector<std::unique_ptr<BrickBatch<T>>> batches;
    std::vector<std::vector<T>> inputs;
    std::size_t subnormal = 0, nonfinite = 0, count = 0;
    for (std::size_t g = 0; g < shapes.size(); ++g) {
        auto& batch =
            *batches.emplace_back(std::make_unique<BrickBatch<T>>(cc, shapes[g], members[g].size()));
        std::vector<T> in(batch.brickStride() * batch.count(), T(0)); // row padding stays zero
        if (!zero)
            for (std::size_t i = 0; i < members[g].size(); ++i)
                decodeBrick(file, h, members[g][i],
                            reinterpret_cast<std::int32_t*>(in.data()) + i * batch.brickStride(),
                            batch.pitch(), path);
        if constexpr (std::is_same_v<T, float>)
            for (float v : in) {
                subnormal += std::fpclassify(v) == FP_SUBNORMAL;
                nonfinite += !std::isfinite(v);
            }
        count += in.size();
        inputs.push_back(std::move(in));
    }
    std::vector<BrickBatch<T>*> all;
    for (auto& b : batches)
        all.push_back(b.get());
    std::vector<double> wall, kernel, cpu;
    std::vector<std::pair<int, double>> threads0;
    for (int r = 0; r < runs + 1; ++r) { // run 0 is a warm-up
        for (std::size_t g = 0; g < batches.size(); ++g) {
            BatchMapping<T> m = batches[g]->mapForWrite(cc);
            std::copy(inputs[g].begin(), inputs[g].end(), m.data());
        }
        cc.finish();
        const double cpu0 = processCpuMs();
        Stopwatch sw;
        std::unique_ptr<LiftingTransform<T>> fresh;
        if (freshTransform) fresh = std::make_unique<LiftingTransform<T>>(cc, h.wavelet);
        const double k = (fresh ? *fresh : t).inverse(cc, std::span<BrickBatch<T>* const>(all), h.levels);
        cc.finish();
        const double ms = sw.milliseconds();
        if (r == 0) {
            threads0 = threadRunMs();
            continue;
        }
        wall.push_back(ms);
        cpu.push_back(processCpuMs() - cpu0);
        kernel.push_back(k);
    }
    std::vector<double> sorted = wall;
    std::sort(sorted.begin(), sorted.end());
    std::printf("%s: %s %s, %d levels, %zu bricks in %zu shapes, %zu values (%zu subnormal, %zu "
                "non-finite)%s, AnonHugePages %ld kB\n",
                path.c_str(), waveletName(h.wavelet).data(), std::is_same_v<T, float> ? "float" : "int32",
                h.levels, h.brickCount(), shapes.size(), count, subnormal, nonfinite, zero ? " zeroed" : "",
                anonHugeKb());
    std::printf(
        "inverse wall ms: median %.2f min %.2f max %.2f; kernel median %.2f; process CPU median %.2f; runs:",
        median(wall), sorted.front(), sorted.back(), median(kernel), median(cpu));
    for (double w : wall)
        std::printf(" %.2f", w);
    std::printf("\nthread run ms over the timed runs (tid: ms):");
    for (const auto& [tid, ms] : threadRunMs()) {
        double before = 0;
        for (const auto& [t0, m0] : threads0)
            if (t0 == tid) before = m0;
        if (ms - before > 0.05) std::printf(" %d: %.1f", tid, ms - before);
    }
    std::printf("\n");
    return 0;
}

} // namespace

int main(int argc, char** argv) try {
    if (argc < 2) {
        std::fprintf(stderr,
                     "usage: %s FILE.vcz [RUNS] [--zero]  (inverse of every brick, median wall time; "
                     "--zero: all coefficients zero)\n",
                     argv[0]);
        return 2;
    }
    const int runs = argc > 2 ? std::max(1, std::atoi(argv[2])) : 7;
    bool zero = false;
    for (int a = 3; a < argc; ++a) {
        const std::string o = argv[a];
        zero |= o == "--zero";
        if (o == "--no-thp") prctl(PR_SET_THP_DISABLE, 1, 0, 0, 0); // before any batch is allocated
        if (o == "--fresh") freshTransform = true;
    }
    const VczHeader h = readVczHeader(readFile(argv[1]), argv[1]);
    if (h.transform == TransformKind::FloatLifting) return run<float>(argv[1], runs, zero);
    if (h.transform == TransformKind::IntegerLifting) return run<std::int32_t>(argv[1], runs, zero);
    std::fprintf(stderr, "%s: no lifting transform in this file\n", argv[1]);
    return 2;
} catch (const std::exception& e) {
    std::fprintf(stderr, "volcl-bench-inverse: %s\n", e.what());
    return 1;
}
