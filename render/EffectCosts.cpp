// Measured effect costs: frames with and without each compiled effect.
#include "render/EffectCosts.hpp"

#include "core/runtime/Timing.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace volcl {
double timeFrames(VolumeRenderer& r, const Scene& s, int runs, ImageBuffer* image) {
    r.setScene(s);
    ImageBuffer img = r.render(); // warm-up: kernel build and first-touch excluded
    std::vector<double> ms;
    for (int i = 0; i < std::max(runs, 1); ++i) {
        img = r.render();
        ms.push_back(r.lastKernelMilliseconds());
    }
    if (image) *image = std::move(img);
    return median(ms);
}

namespace {

std::string fixed(double v, int digits) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(digits) << v;
    return os.str();
}

} // namespace

std::string CostReport::text() const {
    std::ostringstream os;
    os << "cost (measured, " << width << "x" << height << ", median of " << runs << " frames, kernel ms):\n";
    os << "  plain frame (no effects, no tables, no skipping): " << fixed(plainMs, 2) << " ms\n";
    for (const auto& e : effects) {
        os << "  " << e.effect << ": " << (e.addedMs >= 0 ? "+" : "") << fixed(e.addedMs, 2)
           << " ms = " << (e.addedMs >= 0 ? "+" : "") << fixed(plainMs > 0 ? e.addedMs / plainMs : 0.0, 2)
           << " plain frames\n";
    }
    os << "  this frame: " << fixed(frameMs, 2) << " ms = " << fixed(plainMs > 0 ? frameMs / plainMs : 0.0, 2)
       << " x the plain frame\n";
    return os.str();
}

CostReport measureEffectCosts(VolumeRenderer& r, int runs, long maxPixels) {
    const Scene original = r.scene();
    Scene base = original;
    base.camera = r.camera();
    const double pixels = double(base.width) * double(base.height);
    if (pixels > double(maxPixels)) {
        const double f = std::sqrt(double(maxPixels) / pixels);
        base.width = std::max(1, int(std::lround(base.width * f)));
        base.height = std::max(1, int(std::lround(base.height * f)));
    }
    const EffectPlan plan = r.planEffects(base);
    CostReport rep;
    rep.width = base.width;
    rep.height = base.height;
    rep.runs = runs;

    Scene plain = base;
    plain.effects = {};
    plain.lights.clear();
    plain.preintegration = Preintegration::None;
    plain.skipping = false;
    if (plain.mode == RenderMode::Iso) plain.mode = RenderMode::Dvr; // iso mode needs its surfaces
    rep.plainMs = timeFrames(r, plain, runs);
    rep.frameMs = timeFrames(r, base, runs);

    struct Toggle {
        const char* name;
        bool on;
        std::function<void(Scene&)> remove;
    };
    const std::vector<Toggle> toggles = {
        {"shading", plan.shading, [](Scene& s) { s.effects.shading = false; }},
        {"shadows", plan.shadows, [](Scene& s) { s.effects.shadows = false; }},
        {"scattering", plan.scattering, [](Scene& s) { s.effects.scattering = false; }},
        {"fog", plan.fog, [](Scene& s) { s.effects.fog.enabled = false; }},
        {"clipping", plan.clipping, [](Scene& s) { s.effects.clipPlanes.clear(); }},
        {"isosurfaces", !plan.isosurfaces.empty() && base.mode == RenderMode::Dvr,
         [](Scene& s) { s.effects.isosurfaces.clear(); }},
        {"pre-integration", base.preintegration != Preintegration::None && base.mode == RenderMode::Dvr,
         [](Scene& s) { s.preintegration = Preintegration::None; }},
        {"empty-space skipping", plan.skipping, [](Scene& s) { s.skipping = false; }},
        {"early termination", plan.earlyTermination, [](Scene& s) { s.earlyTermination = 1.0; }},
    };
    for (const auto& t : toggles) {
        if (!t.on) continue;
        Scene without = base;
        t.remove(without);
        EffectCost c;
        c.effect = t.name;
        c.withoutMs = timeFrames(r, without, runs);
        c.addedMs = rep.frameMs - c.withoutMs;
        rep.effects.push_back(c);
    }
    r.setScene(original);
    return rep;
}

} // namespace volcl
