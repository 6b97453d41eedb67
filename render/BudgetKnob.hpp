// The accuracy knobs the frame-time budget planner may turn: each is a route (how the frame is drawn: ray
// marched, path traced) with one value whose frame time and error follow a power law.
#pragma once

#include "render/VolumeRenderer.hpp"

#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace volcl {

/// How a knob's error behaves. A discretisation error is deterministic: two probe images differ by
/// C |v1^p - v0^p|. Monte Carlo noise is independent between seeds: two probes differ by C sqrt(v0^2p +
/// v1^2p), and the route converges to the reference image, which makes it the yardstick for the other routes'
/// bias.
enum class KnobError { Discretisation, MonteCarlo };

/// One knob: frame time ~ A + B value^costExponent, error ~ C value^errorExponent on top of its route's bias.
/// A new knob (another route, another accuracy parameter) is one more factory returning this; the planner
/// does not know knobs by name.
struct BudgetKnob {
    std::string name;                  ///< the scene field it sets: "render.step"
    std::string route;                 ///< how frames on this knob are drawn, for the report
    double lo = 0.0, hi = 0.0;         ///< allowed values
    double probe0 = 0.0, probe1 = 0.0; ///< the two calibration values (cheap ones, a factor 2 apart)
    double costExponent = -1.0, errorExponent = 2.0;
    KnobError error = KnobError::Discretisation;
    bool integer = false;              ///< only whole values (samples per pixel)
    std::function<void(Scene&)> enter; ///< puts a scene on this knob's route
    std::function<double(const Scene&)> get;
    std::function<void(Scene&, double)> set;
    std::function<void(Scene&, int)> reseed; ///< Monte Carlo: an independent random stream for probe i
};

/// The ray marcher's step (single scattering when the scene scatters): from 1/16 of the scene's step up to a
/// quarter of the box diagonal; time ~ 1 / step (samples per ray), error ~ step^2 (midpoint rule).
BudgetKnob stepKnob(const Scene& scene, const WorldBox& box);

/// The path tracer's samples per pixel (multiple scattering): time ~ n, error ~ n^-1/2. Only when the scene
/// scatters and the renderer would path-trace it; otherwise none.
std::optional<BudgetKnob> samplesKnob(const VolumeRenderer& renderer, const Scene& scene);

/// Every knob the renderer offers for the scene, the ray step first.
std::vector<BudgetKnob> budgetKnobs(const VolumeRenderer& renderer, const Scene& scene);

} // namespace volcl
