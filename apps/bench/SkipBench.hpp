// `volcl bench render --skip-sweep`: empty-space skipping auto, on and off at each step, timed in interleaved
// rounds.
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"

#include <filesystem>
#include <vector>

namespace volcl::cli {

struct SkipBenchOptions {
    std::vector<double> steps; ///< world units
    int rounds = 9;            ///< interleaved rounds (one frame of each mode per round)
    std::filesystem::path csv; ///< rows: step, mode, median ms, interval, choice (empty: none)
};

/// For each step: one renderer per skipping mode (auto decides while it is built), then `rounds` rounds of
/// one frame each, interleaved; prints medians, auto's choice, and auto against the better of on and off as
/// a ratio and as the median paired difference with its 95% interval ("within noise" when it holds 0).
void benchSkipping(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                   const Scene& scene, const SkipBenchOptions& options);

} // namespace volcl::cli
