// `volcl bench render --shadow-sweep`: shadows from light-attenuation volumes against the exact secondary-ray
// method: build time, frame time relative to the plain and the shaded frame, and error, per light kind.
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"

#include <filesystem>
#include <vector>

namespace volcl::cli {

struct ShadowBenchOptions {
    int rounds = 5;                  ///< interleaved timing rounds (median)
    std::vector<int> cells{1, 2, 4}; ///< light_volume_cell values measured
    std::vector<double> raySteps{
        1, 2};                 ///< shadow steps of the ray method, in voxel spacings (first: the reference)
    std::filesystem::path csv; ///< rows: light, method, knob, build_ms, ms, ratio_plain, rmse (empty: none)
};

/// For a directional light and a head light: the plain frame (no lights, no effects), the shaded frame without
/// shadows, shaded frames with shadows from light volumes of each cell size and by secondary rays at each step,
/// timed in interleaved rounds on one renderer each (the ray frames, tens of times slower, once each); RMSE of
/// RGBA against the ray method at the first step. Prints a table and the shadowed/plain ratio on stdout.
void benchShadows(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                  const Scene& scene, const ShadowBenchOptions& options);

} // namespace volcl::cli
