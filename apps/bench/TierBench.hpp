// `volcl bench render --tiers`: the grid's preview tiers (shear-warp, discrete ray casting) against the ray
// marcher, in time and error.
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"

#include <string>
#include <vector>

namespace volcl::cli {

struct TierBenchOptions {
    std::vector<double>
        steps;      ///< ray-marcher steps in voxels of the finest spacing (the error-vs-time curve)
    int rounds = 7; ///< interleaved rounds: every configuration renders once per round
    double referenceStep = 0.05; ///< the double reference's step, in voxels
    std::string csv;             ///< rows for bench/render/plot_tiers.py; empty: none
};

/// Times the ray marcher at each step (point sampling, skipping as the scene says), shear-warp and discrete
/// ray casting on `scene`, interleaved over `rounds` rounds (kernel milliseconds, medians), and measures each
/// image's RMSE against the double reference. Prints the table with the load average and each time's ratio
/// to the ray marcher at the scene's own step.
void benchTiers(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf, const Scene& scene,
                const TierBenchOptions& o);

} // namespace volcl::cli
