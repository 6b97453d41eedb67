// What each compiled effect costs on a renderer's data (measured: the frame with and without it, relative to
// the plain frame).
#pragma once

#include "core/runtime/Timing.hpp"
#include "render/VolumeRenderer.hpp"

#include <string>
#include <vector>

namespace volcl {

/// One effect's measured cost: the scene's frame against the same frame without the effect, in the same
/// rounds.
struct EffectCost {
    std::string effect;     ///< "fog", "shading", ...
    double withoutMs = 0.0; ///< the frame without this effect (median)
    /// Median of the rounds' paired differences frame - without (negative: the effect saves time, e.g.
    /// skipping) and its distribution-free confidence interval.
    MedianInterval added;
    /// The interval holds 0: the sign of the cost is not established, it is reported as "within noise".
    bool withinNoise() const noexcept { return added.holdsZero(); }
};

/// Frame times of a scene: the plain frame (no effects, no tables, no skipping), the scene's, and each
/// compiled effect's share. Every variant is rendered once per round, the rounds interleaved (a load change
/// hits all variants alike), after a warm-up round (kernel builds excluded); medians of kernel times.
struct CostReport {
    int width = 0, height = 0, rounds = 0;
    std::string load; ///< the load average when the measurement ended (loadAverageText())
    double plainMs = 0.0, frameMs = 0.0;
    std::vector<EffectCost> effects;
    /// "  fog: +1.23 ms = +0.41 plain frames (95% interval +1.10 to +1.31)", "  empty-space skipping: within
    /// noise (95% interval -0.20 to +0.31 ms)" lines, the header with rounds and load, and the totals.
    std::string text() const;
};

/// Measures the renderer's current scene: the plain frame, the full frame, and the frame with each compiled
/// effect removed, in `rounds` interleaved rounds. Frames larger than `maxPixels` are measured at a
/// proportionally smaller size (cost ratios do not depend on it). Leaves the renderer on its original scene.
CostReport measureEffectCosts(VolumeRenderer& renderer, int rounds = 7, long maxPixels = 256L * 256L);

/// Sets the scene, renders a warm-up frame (kernel build and first touch excluded), then `runs` frames;
/// returns the median kernel milliseconds and, in `last`, the last image.
double timeFrames(VolumeRenderer& renderer, const Scene& scene, int runs, ImageBuffer* last = nullptr);

} // namespace volcl
