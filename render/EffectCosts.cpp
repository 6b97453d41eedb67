// Measured effect costs: frames with and without each compiled effect.
#include "render/EffectCosts.hpp"

#include "core/runtime/Timing.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
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

std::string signedMs(double v) {
    std::string s = fixed(v, 2);
    if (v >= 0) s.insert(s.begin(), '+');
    return s;
}

} // namespace

std::string CostReport::text() const {
    std::ostringstream os;
    os << "cost (measured, " << width << "x" << height << ", medians of " << rounds
       << " interleaved rounds, kernel ms; load " << load << "):\n";
    os << "  plain frame (no effects, no tables, no skipping): " << fixed(plainMs, 2) << " ms\n";
    for (const auto& e : effects) {
        const std::string interval = std::to_string(int(std::floor(e.added.level * 100.0))) + "% interval " +
                                     signedMs(e.added.lo) + " to " + signedMs(e.added.hi);
        if (e.withinNoise()) {
            os << "  " << e.effect << ": within noise (" << interval << " ms)\n";
            continue;
        }
        os << "  " << e.effect << ": " << signedMs(e.added.median)
           << " ms = " << signedMs(plainMs > 0 ? e.added.median / plainMs : 0.0) << " plain frames ("
           << interval << ")\n";
    }
    os << "  this frame: " << fixed(frameMs, 2) << " ms = " << fixed(plainMs > 0 ? frameMs / plainMs : 0.0, 2)
       << " x the plain frame\n";
    return os.str();
}

CostReport measureEffectCosts(VolumeRenderer& r, int rounds, long maxPixels) {
    const Scene original = r.scene();
    Scene base = original;
    base.camera = r.camera();
    const double pixels = double(base.width) * double(base.height);
    if (pixels > double(maxPixels)) {
        const double f = std::sqrt(double(maxPixels) / pixels);
        base.width = std::max(1, int(std::lround(base.width * f)));
        base.height = std::max(1, int(std::lround(base.height * f)));
    }
    r.setScene(base);
    const EffectPlan plan = r.plan(); // as built: skipping auto may have measured itself off
    CostReport rep;
    rep.width = base.width;
    rep.height = base.height;
    rep.rounds = std::max(rounds, 1);

    Scene plain = base;
    plain.effects = {};
    plain.lights.clear();
    plain.preintegration = Preintegration::None;
    plain.skipping = SkipMode::Off;
    if (plain.mode == RenderMode::Iso) plain.mode = RenderMode::Dvr; // iso mode needs its surfaces

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
        {"clipping", plan.clipping,
         [](Scene& s) {
             s.effects.clipPlanes.clear();
             s.effects.cropBox.reset();
         }},
        {"isosurfaces", !plan.isosurfaces.empty() && base.mode == RenderMode::Dvr,
         [](Scene& s) { s.effects.isosurfaces.clear(); }},
        {"pre-integration", base.preintegration != Preintegration::None && base.mode == RenderMode::Dvr,
         [](Scene& s) { s.preintegration = Preintegration::None; }},
        {"empty-space skipping", plan.skipping, [](Scene& s) { s.skipping = SkipMode::Off; }},
        {"early termination", plan.earlyTermination, [](Scene& s) { s.earlyTermination = 1.0; }},
    };
    // Variant 0 is the plain frame, 1 the scene's, then one per compiled effect without it.
    std::vector<Scene> variants{plain, base};
    std::vector<const char*> names;
    for (const auto& t : toggles) {
        if (!t.on) continue;
        Scene without = base;
        t.remove(without);
        variants.push_back(without);
        names.push_back(t.name);
    }
    std::vector<std::vector<double>> ms(variants.size());
    for (int round = -1; round < rep.rounds; ++round) // round -1: warm-up (kernel builds, first touch)
        for (std::size_t v = 0; v < variants.size(); ++v) {
            r.setScene(variants[v]);
            r.render();
            if (round >= 0) ms[v].push_back(r.lastKernelMilliseconds());
        }
    rep.load = loadAverageText();
    rep.plainMs = median(ms[0]);
    rep.frameMs = median(ms[1]);
    for (std::size_t i = 0; i < names.size(); ++i) {
        const std::vector<double>& without = ms[i + 2];
        std::vector<double> diff;
        for (std::size_t k = 0; k < without.size(); ++k)
            diff.push_back(ms[1][k] - without[k]);
        EffectCost c;
        c.effect = names[i];
        c.withoutMs = median(without);
        c.added = medianInterval(diff);
        rep.effects.push_back(c);
    }
    r.setScene(original);
    return rep;
}

} // namespace volcl
