// The budget planner's knobs: the ray step of the ray marcher and the path tracer's samples per pixel.
#include "render/BudgetKnob.hpp"

#include "render/VecMath.hpp"

#include <algorithm>
#include <cmath>

namespace volcl {

BudgetKnob stepKnob(const Scene& scene, const WorldBox& box) {
    BudgetKnob k;
    k.name = "render.step";
    k.route = scene.effects.scattering ? "single scattering, ray marched" : "ray marched";
    k.lo = scene.step / 16.0;
    k.hi = std::max(scene.step, 0.25 * norm(box.extent));
    k.probe0 = scene.step;
    k.probe1 = std::min(2.0 * scene.step, k.hi);
    k.costExponent = -1.0; // samples per ray ~ 1 / step
    k.errorExponent = 2.0; // midpoint rule / pre-integrated segments: error ~ step^2
    k.enter = [](Scene& s) { s.effects.scatteringOrder = ScatteringOrder::Single; };
    k.get = [](const Scene& s) { return s.step; };
    k.set = [](Scene& s, double v) { s.step = v; };
    return k;
}

std::optional<BudgetKnob> samplesKnob(const VolumeRenderer& renderer, const Scene& scene) {
    if (!scene.effects.scattering) return std::nullopt;
    Scene traced = scene;
    traced.effects.scatteringOrder = ScatteringOrder::Multiple;
    if (!renderer.planEffects(traced).pathTracing) return std::nullopt; // no path tracer, or nothing to light
    BudgetKnob k;
    k.name = "effects.scattering.samples";
    k.route = "multiple scattering, path traced";
    k.lo = 1.0;
    k.hi = double(1 << 20); // the scene's own limit
    k.probe0 = 1.0;
    k.probe1 = 2.0;
    k.costExponent = 1.0;   // one path per pixel per sample
    k.errorExponent = -0.5; // Monte Carlo
    k.error = KnobError::MonteCarlo;
    k.integer = true;
    k.enter = [](Scene& s) { s.effects.scatteringOrder = ScatteringOrder::Multiple; };
    k.get = [](const Scene& s) { return double(s.effects.samples); };
    k.set = [](Scene& s, double v) { s.effects.samples = int(std::lround(v)); };
    // Seeds far from the scene's own: the probes are independent of each other and of the final frame.
    const std::uint32_t seed = scene.effects.seed;
    k.reseed = [seed](Scene& s, int i) { s.effects.seed = seed + 0x9E3779B9u * std::uint32_t(i + 1); };
    return k;
}

std::vector<BudgetKnob> budgetKnobs(const VolumeRenderer& renderer, const Scene& scene) {
    std::vector<BudgetKnob> knobs{stepKnob(scene, renderer.bounds())};
    if (auto k = samplesKnob(renderer, scene)) knobs.push_back(std::move(*k));
    return knobs;
}

} // namespace volcl
