// What each compiled effect costs on a renderer's data (measured: the frame with and without it, relative to
// the plain frame), and the frame-time budget planner that picks the accuracy knobs to fit a budget.
#pragma once

#include "host/render/VolumeRenderer.hpp"

#include <functional>
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

/// An accuracy knob the budget planner may turn: frame time ~ value^costExponent, error ~ value^errorExponent
/// around the measured point. The ray step is one (time ~ 1 / step, error ~ step^2); the Monte Carlo path
/// tracer's samples per pixel plug in the same way (time ~ n, error ~ n^-1/2).
struct BudgetKnob {
    std::string name;   ///< "render.step"
    double lo = 0.0, hi = 0.0; ///< allowed values
    double costExponent = -1.0, errorExponent = 2.0;
    std::function<double(const Scene&)> get;
    std::function<void(Scene&, double)> set;
};

/// The ray step as a budget knob: from 1/16 of the scene's step up to a quarter of the box diagonal.
BudgetKnob stepKnob(const Scene& scene, const WorldBox& box);

/// What the planner chose for a frame-time budget, with its prediction, the measured frame and the expected
/// error (RMSE over R, G, B, A against the converged image, from the knob's error law fitted by doubling).
struct BudgetChoice {
    double budgetMs = 0.0;
    std::string knob;
    double value = 0.0;
    double predictedMs = 0.0, measuredMs = 0.0;
    double expectedError = 0.0;
    std::vector<std::string> notes; ///< the probes and fits, in order
    bool met(double tolerance = 0.2) const { return std::abs(measuredMs - budgetMs) <= tolerance * budgetMs; }
    std::string text() const;
};

/// Fits the renderer's frame time to `budgetMs` with the first knob (probing frames: time = A + B value^k
/// fitted to two probes, refined by up to three corrective frames), leaves the renderer on the chosen
/// scene and reports. Throws UsageError for a budget <= 0.
BudgetChoice fitBudget(VolumeRenderer& renderer, double budgetMs, const std::vector<BudgetKnob>& knobs,
                       int runs = 3);

} // namespace volcl
