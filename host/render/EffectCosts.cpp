// Measured effect costs (frames with and without each compiled effect) and the frame-time budget planner.
#include "host/render/EffectCosts.hpp"

#include "host/Error.hpp"
#include "host/render/Reference.hpp"
#include "host/render/VecMath.hpp"
#include "host/runtime/Timing.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace volcl {
namespace {

double timeScene(VolumeRenderer& r, const Scene& s, int runs, ImageBuffer* image = nullptr) {
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
        os << "  " << e.effect << ": " << (e.addedMs >= 0 ? "+" : "") << fixed(e.addedMs, 2) << " ms = "
           << (e.addedMs >= 0 ? "+" : "") << fixed(plainMs > 0 ? e.addedMs / plainMs : 0.0, 2)
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
    rep.plainMs = timeScene(r, plain, runs);
    rep.frameMs = timeScene(r, base, runs);

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
        c.withoutMs = timeScene(r, without, runs);
        c.addedMs = rep.frameMs - c.withoutMs;
        rep.effects.push_back(c);
    }
    r.setScene(original);
    return rep;
}

BudgetKnob stepKnob(const Scene& scene, const WorldBox& box) {
    BudgetKnob k;
    k.name = "render.step";
    k.lo = scene.step / 16.0;
    k.hi = std::max(scene.step, 0.25 * norm(box.extent));
    k.costExponent = -1.0; // samples per ray ~ 1 / step
    k.errorExponent = 2.0; // midpoint rule / pre-integrated segments: error ~ step^2
    k.get = [](const Scene& s) { return s.step; };
    k.set = [](Scene& s, double v) { s.step = v; };
    return k;
}

std::string BudgetChoice::text() const {
    std::ostringstream os;
    os << "budget " << fixed(budgetMs, 1) << " ms: " << knob << " " << value << ", predicted "
       << fixed(predictedMs, 1) << " ms, measured " << fixed(measuredMs, 1) << " ms ("
       << (measuredMs >= budgetMs ? "+" : "") << fixed(100.0 * (measuredMs - budgetMs) / budgetMs, 1)
       << "%), expected error RMSE " << std::setprecision(2) << std::scientific << expectedError
       << std::defaultfloat << " (from step doubling)\n";
    for (const auto& n : notes)
        os << "  " << n << '\n';
    return os.str();
}

BudgetChoice fitBudget(VolumeRenderer& r, double budgetMs, const std::vector<BudgetKnob>& knobs, int runs) {
    if (!(budgetMs > 0.0) || !std::isfinite(budgetMs)) throw UsageError("render.budget_ms must be > 0");
    if (knobs.empty()) throw UsageError("budget planner: no knob to turn");
    const BudgetKnob& k = knobs.front();
    Scene s = r.scene();
    BudgetChoice c;
    c.budgetMs = budgetMs;
    c.knob = k.name;
    const double v0 = std::clamp(k.get(s), k.lo, k.hi);
    const double v1 = std::clamp(k.costExponent < 0 ? 2.0 * v0 : 0.5 * v0, k.lo, k.hi);
    struct Probe {
        double v, ms;
    };
    std::vector<Probe> probes;
    ImageBuffer img0, img1;
    k.set(s, v0);
    probes.push_back({v0, timeScene(r, s, runs, &img0)});
    k.set(s, v1);
    probes.push_back({v1, timeScene(r, s, runs, &img1)});
    for (const auto& p : probes)
        c.notes.push_back("probe " + k.name + " " + fixed(p.v, 4) + ": " + fixed(p.ms, 2) + " ms");
    // Error law err = C v^p fitted by the doubled probe: |I(v1) - I(v0)| ~ C |v1^p - v0^p|.
    const double p = k.errorExponent;
    const double d = imageRmse(img0, img1);
    const double C = d / std::abs(std::pow(v1, p) - std::pow(v0, p));

    auto solve = [&](const Probe& a, const Probe& b, double& predicted) {
        const double xa = std::pow(a.v, k.costExponent), xb = std::pow(b.v, k.costExponent);
        double B = xb != xa ? (b.ms - a.ms) / (xb - xa) : 0.0, A = a.ms - B * xa;
        if (!(B > 0.0)) { // noise or a flat law: proportional through the nearer probe
            B = a.ms / xa;
            A = 0.0;
        }
        const double x = (budgetMs - A) / B;
        double v = x > 0.0 ? std::pow(x, 1.0 / k.costExponent) : (k.costExponent < 0 ? k.hi : k.lo);
        v = std::clamp(v, k.lo, k.hi);
        predicted = A + B * std::pow(v, k.costExponent);
        return v;
    };
    double predicted = 0.0;
    double v = solve(probes[0], probes[1], predicted);
    struct Try {
        double v, predicted, ms;
    };
    std::vector<Try> tries;
    for (int it = 0; it < 4; ++it) {
        k.set(s, v);
        const double ms = timeScene(r, s, runs);
        tries.push_back({v, predicted, ms});
        c.notes.push_back("try " + k.name + " " + fixed(v, 4) + ": predicted " + fixed(predicted, 2) +
                          " ms, measured " + fixed(ms, 2) + " ms");
        if (std::abs(ms - budgetMs) <= 0.05 * budgetMs) break;
        // At the knob's fast end and still too slow, or its accurate end and still too fast: nothing to gain.
        const bool fastEnd = k.costExponent < 0 ? v == k.hi : v == k.lo;
        const bool slowEnd = k.costExponent < 0 ? v == k.lo : v == k.hi;
        if ((fastEnd && ms > budgetMs) || (slowEnd && ms < budgetMs)) break;
        // Refit through this frame and the probe closest to the budget.
        probes.push_back({v, ms});
        std::sort(probes.begin(), probes.end(), [&](const Probe& a, const Probe& b) {
            return std::abs(a.ms - budgetMs) < std::abs(b.ms - budgetMs);
        });
        double pr = 0.0;
        const double nv = solve(probes[0], probes[1], pr);
        if (nv == v) break;
        v = nv;
        predicted = pr;
    }
    // The measured frame closest to the budget is the choice; the renderer is left on it.
    const Try best = *std::min_element(tries.begin(), tries.end(), [&](const Try& a, const Try& b) {
        return std::abs(a.ms - budgetMs) < std::abs(b.ms - budgetMs);
    });
    v = best.v;
    const double ms = best.ms;
    if (best.v != tries.back().v) {
        k.set(s, v);
        r.setScene(s);
    }
    const bool atFastEnd = k.costExponent < 0 ? v == k.hi : v == k.lo;
    if (ms > 1.2 * budgetMs && atFastEnd)
        c.notes.push_back("the budget is below this scene's fixed cost: " + k.name + " at its fastest value");
    c.value = v;
    c.predictedMs = best.predicted;
    c.measuredMs = ms;
    // RGBA lies in [0, 1]: an RMSE above 1 only says the law was extrapolated past its range.
    c.expectedError = std::min(C * std::pow(v, p), 1.0);
    const double vMin = std::min(v0, v1), vMax = std::max(v0, v1);
    if (v < 0.25 * vMin || v > 4.0 * vMax)
        c.notes.push_back("expected error extrapolated from probes at " + fixed(vMin, 4) + ".." + fixed(vMax, 4) +
                          ": far outside them the step^2 law is only a trend");
    return c;
}

} // namespace volcl
