// `volcl bench render --budgets`: the frame-time budget planner on a scene, each budget's choice timed again
// in interleaved rounds and compared with a converged reference.
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"

#include <filesystem>
#include <vector>

namespace volcl::cli {

struct BudgetBenchOptions {
    std::vector<double> budgetsMs;
    int runs = 3;               ///< frames per planner measurement (median)
    int rounds = 5;             ///< interleaved timing rounds over all budgets' choices
    int referenceSamples = 256; ///< path tracer samples per pixel of the reference (scattering scenes)
    std::filesystem::path csv;  ///< rows: budget, knob, value, ms, rmse (empty: none)
};

/// Plans every budget (fitBudget with the renderer's knobs), then times each choice once per round with the
/// budgets interleaved (the median is the achieved frame time) and measures its RMSE against the reference:
/// the path tracer at `referenceSamples` with another seed when the scene scatters, else the ray marcher at
/// 1/32 of the scene's step. Prints the planner's reports and a table on stdout.
void benchBudgets(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                  const Scene& scene, const BudgetBenchOptions& options);

} // namespace volcl::cli
