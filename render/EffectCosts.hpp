// What each compiled effect costs on a renderer's data (measured: the frame with and without it, relative to
// the plain frame).
#pragma once

#include "render/VolumeRenderer.hpp"

#include <string>
#include <vector>

namespace volcl {

/// One effect's measured cost: the scene's frame against the same frame without the effect.
struct EffectCost {
    std::string effect;     ///< "fog", "shading", ...
    double withoutMs = 0.0; ///< the frame without this effect
    double addedMs = 0.0;   ///< frame - withoutMs (negative: the effect saves time, e.g. skipping)
};

/// Frame times of a scene: the plain frame (no effects, no tables, no skipping), the scene's, and each
/// compiled effect's share. Medians of `runs` kernel times after a warm-up (kernel builds excluded).
struct CostReport {
    int width = 0, height = 0, runs = 0;
    double plainMs = 0.0, frameMs = 0.0;
    std::vector<EffectCost> effects;
    /// "  fog: +1.23 ms = 0.41 plain frames (measured)" lines and the totals.
    std::string text() const;
};

/// Measures the renderer's current scene: the plain frame, the full frame, and the frame with each compiled
/// effect removed. Frames larger than `maxPixels` are measured at a proportionally smaller size (cost
/// ratios do not depend on it). Leaves the renderer on its original scene.
CostReport measureEffectCosts(VolumeRenderer& renderer, int runs = 3, long maxPixels = 256L * 256L);

/// Sets the scene, renders a warm-up frame (kernel build and first touch excluded), then `runs` frames;
/// returns the median kernel milliseconds and, in `last`, the last image.
double timeFrames(VolumeRenderer& renderer, const Scene& scene, int runs, ImageBuffer* last = nullptr);

} // namespace volcl
