// `volcl bench render --tiers`: preview tiers against the ray marcher, interleaved, with RMSE.
#include "apps/bench/TierBench.hpp"

#include "apps/bench/BenchOutput.hpp"
#include "apps/bench/MeshBench.hpp"
#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "core/runtime/Timing.hpp"
#include "host/image/ImageIo.hpp"
#include "render/VolumeRenderer.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace volcl::cli {

void benchTiers(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf, const Scene& scene,
                const TierBenchOptions& o) {
    const Volume* grid = input.grid();
    if (!grid) throw UsageError("bench render: --tiers measures grids (give a volume)");
    if (o.rounds < 1) throw UsageError("bench render: --tiers needs at least one round");
    const double voxel = std::min({grid->spacing[0], grid->spacing[1], grid->spacing[2]});
    struct Config {
        std::string method;
        double stepVoxels = 0.0;
        std::unique_ptr<VolumeRenderer> renderer;
        std::vector<double> ms;
    };
    std::vector<Config> configs;
    for (double st : o.steps) {
        Scene s = scene;
        s.gridMethod = GridMethod::Raymarch;
        s.step = st * voxel;
        configs.push_back({"raymarch", st, input.makeRenderer(cc, tf, s), {}});
    }
    for (GridMethod m : {GridMethod::ShearWarp, GridMethod::Drc}) {
        Scene s = scene;
        s.gridMethod = m;
        configs.push_back(
            {std::string(gridMethodName(m)), scene.step / voxel, input.makeRenderer(cc, tf, s), {}});
    }
    for (Config& c : configs)
        c.renderer->render(); // builds encodings, tables and kernels before the timed rounds
    for (int round = 0; round < o.rounds; ++round)
        for (Config& c : configs) {
            c.renderer->render();
            c.ms.push_back(c.renderer->lastKernelMilliseconds());
        }
    const ImageBuffer ref = input.renderReference(tf, scene, {.step = o.referenceStep * voxel});
    // The peer every tier is compared with: the ray marcher at the scene's own step.
    double peerMs = 0.0;
    for (const Config& c : configs)
        if (c.method == "raymarch" && std::abs(c.stepVoxels * voxel - scene.step) < 1e-9 * voxel)
            peerMs = median(c.ms);
    std::cout << "preview tiers, " << scene.width << "x" << scene.height << ", median kernel ms of "
              << o.rounds << " interleaved rounds, load average " << loadAverage() << "\n";
    std::cout << "  method       step   ms/frame  ratio to raymarch   RMSE rgba    RMSE rgb\n";
    std::ostringstream csv;
    csv << "method,step,ms_per_frame,ratio,rmse_rgba,rmse_rgb\n";
    for (const Config& c : configs) {
        const ImageBuffer img = c.renderer->render();
        const double ms = median(c.ms), e4 = imageRmse(img, ref), e3 = rmseRgb(img, ref);
        const double ratio = peerMs > 0.0 ? ms / peerMs : 0.0;
        std::cout << "  " << std::left << std::setw(11) << c.method << std::right << std::fixed
                  << std::setprecision(2) << std::setw(6) << c.stepVoxels << std::setw(11) << ms
                  << std::setw(19) << std::setprecision(3) << ratio << "  " << std::scientific
                  << std::setw(10) << e4 << "  " << std::setw(10) << e3 << std::fixed << '\n';
        csv << c.method << ',' << c.stepVoxels << ',' << ms << ',' << ratio << ',' << e4 << ',' << e3 << '\n';
    }
    if (peerMs <= 0.0)
        std::cout << "  (no ratio: --steps does not hold the scene's step, " << scene.step / voxel
                  << " voxels)\n";
    if (!o.csv.empty()) writeOutput(o.csv, "# load average " + loadAverage() + "\n" + csv.str());
}

} // namespace volcl::cli
