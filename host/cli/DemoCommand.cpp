// `volcl demo`: the main job on embedded defaults (generated phantoms, checked against references).
#include "host/Error.hpp"
#include "host/cli/Commands.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/phantoms/Phantoms.hpp"
#include "host/runtime/ClRuntime.hpp"
#include "host/runtime/Timing.hpp"

#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>

namespace volcl::cli {

namespace {

double maxAbsDifference(const Volume& a, const Volume& b) {
    auto x = a.values<float>();
    auto y = b.values<float>();
    double m = 0;
    for (std::size_t i = 0; i < x.size(); ++i) m = std::max(m, std::abs(double(x[i]) - double(y[i])));
    return m;
}

// Voxels where kernel and reference disagree although the sample is not on an ellipsoid surface.
std::size_t sheppLoganMismatches(const Volume& gpu, const Volume& ref) {
    auto x = gpu.values<float>();
    auto y = ref.values<float>();
    const Dims& d = gpu.dims();
    std::size_t bad = 0;
    for (std::size_t k = 0; k < d.z; ++k)
        for (std::size_t j = 0; j < d.y; ++j)
            for (std::size_t i = 0; i < d.x; ++i) {
                std::size_t n = gpu.index(i, j, k);
                if (std::abs(x[n] - y[n]) > 1e-6f &&
                    sheppLoganBoundaryMargin(phantomCoordinate(i, d.x), phantomCoordinate(j, d.y),
                                             phantomCoordinate(k, d.z)) > 1e-5)
                    ++bad;
            }
    return bad;
}

} // namespace

void addDemoCommand(CLI::App& app, GlobalOptions& global) {
    auto* cmd = app.add_subcommand("demo", "Run the pipeline on generated data (Marschner-Lobb, Shepp-Logan)");
    struct Args {
        std::string outDir = "volcl-demo";
        std::size_t mlSize = 41, phantomSize = 128;
    };
    auto a = std::make_shared<Args>();
    cmd->add_option("-o,--output-dir", a->outDir, "Directory for the demo's output files")->capture_default_str();
    cmd->add_option("--ml-size", a->mlSize, "Marschner-Lobb samples per axis")->capture_default_str()->check(
        CLI::Range(std::size_t(2), std::size_t(1024)));
    cmd->add_option("--phantom-size", a->phantomSize, "Shepp-Logan samples per axis")->capture_default_str()->check(
        CLI::Range(std::size_t(2), std::size_t(1024)));
    cmd->callback([a, &global] {
        ComputeContext cc(global.device);
        std::cerr << "volcl demo: device " << cc.device().name << " (" << cc.device().platform << ")\n";
        std::filesystem::create_directories(a->outDir);

        Stopwatch sw;
        Volume ml = generateMarschnerLobb(cc, {a->mlSize, a->mlSize, a->mlSize});
        double mlMs = sw.milliseconds();
        double mlErr = maxAbsDifference(ml, marschnerLobbReference(ml.dims()));
        // float sin/cos of arguments up to 6*2*pi: a few ulp of 40 in the argument, so 1e-5 absolute.
        if (!(mlErr <= 1e-5))
            throw Error("Marschner-Lobb kernel differs from the double reference by " + std::to_string(mlErr));
        std::cerr << "  marschner_lobb " << a->mlSize << "^3 in " << mlMs << " ms (incl. first build), max |kernel - "
                  << "reference| = " << mlErr << '\n';

        sw.restart();
        Volume sl = generateSheppLogan(cc, {a->phantomSize, a->phantomSize, a->phantomSize});
        double slMs = sw.milliseconds();
        std::size_t bad = sheppLoganMismatches(sl, sheppLoganReference(sl.dims()));
        if (bad != 0)
            throw Error("Shepp-Logan kernel differs from the reference at " + std::to_string(bad) + " interior voxels");
        std::cerr << "  shepp_logan " << a->phantomSize << "^3 in " << slMs
                  << " ms (incl. first build), matches the reference off the ellipsoid surfaces\n";

        auto mlPath = std::filesystem::path(a->outDir) / "marschner_lobb.nrrd";
        auto slPath = std::filesystem::path(a->outDir) / "shepp_logan.nrrd";
        writeVolumeFile(ml, mlPath);
        writeVolumeFile(sl, slPath);
        for (const auto& p : {mlPath, slPath}) printVolumeInfo(std::cout, p.string(), readVolumeFile(p), false, global.quiet);
    });
}

} // namespace volcl::cli
