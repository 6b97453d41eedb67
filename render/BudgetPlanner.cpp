// The frame-time budget planner: calibration by probe frames, the choice across knobs, one measured
// correction loop, and the report.
#include "render/BudgetPlanner.hpp"

#include "core/Error.hpp"
#include "render/EffectCosts.hpp"
#include "render/Reference.hpp"

#include <algorithm>
#include <array>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>

namespace volcl {
namespace {

std::string fixed(double v, int digits) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(digits) << v;
    return os.str();
}

std::string sci(double v) {
    std::ostringstream os;
    os << std::scientific << std::setprecision(2) << v;
    return os.str();
}

/// A knob value as the scene will hold it: whole samples, steps to 4 significant digits.
std::string value(const BudgetKnob& k, double v) {
    if (k.integer) return std::to_string(std::llround(v));
    std::ostringstream os;
    os << std::setprecision(4) << v;
    return os.str();
}

std::string percent(double ms, double budgetMs) {
    const double p = 100.0 * (ms - budgetMs) / budgetMs;
    std::string s = p >= 0 ? "+" : "";
    s += fixed(p, 1);
    return s + "%";
}

void checkBudget(double budgetMs) {
    if (!(budgetMs > 0.0) || !std::isfinite(budgetMs))
        throw UsageError("render.budget_ms must be a finite number > 0 (got " + std::to_string(budgetMs) +
                         ")");
}

double fastEnd(const BudgetKnob& k) {
    return k.costExponent < 0 ? k.hi : k.lo;
}
double slowEnd(const BudgetKnob& k) {
    return k.costExponent < 0 ? k.lo : k.hi;
}

struct Probe {
    double v, ms;
};

/// A + B v^k through two frames of distinct values; a non-increasing cost (noise, a flat law) or a negative
/// fixed cost falls back to a proportional law through the first. A frame is never cheaper than nothing:
/// with A < 0 (one frame slowed by the machine's load steepens the line) the law predicts frames of any
/// small time, and a budget of 1e-9 ms looked reachable.
void fitTime(const BudgetKnob& k, const Probe& a, const Probe& b, KnobModel& m) {
    const double xa = std::pow(a.v, k.costExponent), xb = std::pow(b.v, k.costExponent);
    m.B = xb != xa ? (b.ms - a.ms) / (xb - xa) : 0.0;
    m.A = a.ms - m.B * xa;
    if (!(m.B > 0.0) || m.A < 0.0) {
        m.B = a.ms / xa;
        m.A = 0.0;
    }
}

/// A + B v^k by weighted least squares over every frame measured on the knob, each weighted by its closeness
/// to the budget (1 / (1 + (off / 10%)^2)): frames near the budget decide the local law (a law that is only
/// roughly a power law still converges like the secant method), and several of them average the noise of
/// the machine's load instead of one lucky frame steering the fit. Fewer than two distinct values, a
/// non-increasing cost or a negative fixed cost: as fitTime through the nearest.
void fitTimeAll(const BudgetKnob& k, const std::vector<Probe>& frames, double budgetMs, KnobModel& m) {
    double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    const Probe* closest = &frames.front();
    for (const Probe& f : frames) {
        const double x = std::pow(f.v, k.costExponent), off = (f.ms - budgetMs) / (0.1 * budgetMs);
        const double w = 1.0 / (1.0 + off * off);
        sw += w, sx += w * x, sy += w * f.ms, sxx += w * x * x, sxy += w * x * f.ms;
        if (std::abs(f.ms - budgetMs) < std::abs(closest->ms - budgetMs)) closest = &f;
    }
    const double det = sw * sxx - sx * sx;
    if (det > 1e-12 * sw * sxx) {
        m.B = (sw * sxy - sx * sy) / det;
        m.A = (sy - m.B * sx) / sw;
    }
    if (!(det > 1e-12 * sw * sxx) || !(m.B > 0.0) || m.A < 0.0) fitTime(k, *closest, *closest, m);
}

/// The frames of one knob without those the machine's load slowed: with three or more frames, a frame more
/// than 25% slower than the law the other frames fit (fitTimeAll) is left out. Only slow frames are: load
/// never makes a frame faster. A slowed probe near the budget otherwise outweighed every later frame, and
/// the corrections circled (a budget of 30 ms met at 9.5 ms after three tries).
std::vector<Probe> withoutSlowedFrames(const BudgetKnob& k, const std::vector<Probe>& frames,
                                       double budgetMs) {
    if (frames.size() < 3) return frames;
    std::vector<Probe> kept;
    for (std::size_t i = 0; i < frames.size(); ++i) {
        std::vector<Probe> others;
        for (std::size_t j = 0; j < frames.size(); ++j)
            if (j != i) others.push_back(frames[j]);
        KnobModel law;
        fitTimeAll(k, others, budgetMs, law);
        if (!(frames[i].ms > 1.25 * law.timeMs(k, frames[i].v))) kept.push_back(frames[i]);
    }
    return kept.size() >= 2 ? kept : frames;
}

/// The mean of Monte Carlo images weighted by their sample counts: the estimate of all their samples.
ImageBuffer pooled(const ImageBuffer& a, double na, const ImageBuffer& b, double nb) {
    ImageBuffer m = a;
    for (std::size_t i = 0; i < m.pixels.size(); ++i)
        m.pixels[i] = float((na * a.pixels[i] + nb * b.pixels[i]) / (na + nb));
    return m;
}

/// The laws fitted from the probes can be bent by a slowed frame so far that a budget below every frame
/// looks reachable. When the kept frame is still too slow, each knob's fastest value is measured; if every
/// one is more than the tolerance over the budget, the budget is refused like an unreachable one.
void refuseIfFastestTooSlow(VolumeRenderer& r, const std::vector<Scene>& routes,
                            const std::vector<BudgetKnob>& knobs, double budgetMs, int runs) {
    std::ostringstream os;
    os << "render.budget_ms " << budgetMs << " cannot be met within " << fixed(100 * kBudgetTolerance, 0)
       << "%: the fastest frames take";
    for (std::size_t i = 0; i < knobs.size(); ++i) {
        const BudgetKnob& k = knobs[i];
        Scene s = routes[i];
        k.set(s, fastEnd(k));
        const double ms = timeFrames(r, s, runs);
        if (ms <= (1.0 + kBudgetTolerance) * budgetMs) return;
        os << (i ? "," : "") << " " << sci(ms) << " ms at " << k.name << " " << value(k, fastEnd(k)) << " ("
           << k.route << ")";
    }
    throw UsageError(os.str() + " (measured)");
}

} // namespace

double KnobModel::error(const BudgetKnob& k, double v) const {
    const double e = knobError(k, v);
    return std::min(std::sqrt(bias * bias + e * e), 1.0);
}

KnobPick fitKnob(const BudgetKnob& k, const KnobModel& m, double budgetMs) {
    const double x = m.B > 0.0 ? (budgetMs - m.A) / m.B : 0.0;
    double v = x > 0.0 ? std::pow(x, 1.0 / k.costExponent) : fastEnd(k);
    v = std::clamp(std::isfinite(v) ? v : slowEnd(k), k.lo, k.hi);
    if (k.integer) {
        const double a = std::clamp(std::floor(v), k.lo, k.hi), b = std::clamp(std::ceil(v), k.lo, k.hi);
        v = std::abs(m.timeMs(k, a) - budgetMs) <= std::abs(m.timeMs(k, b) - budgetMs) ? a : b;
    }
    KnobPick p;
    p.value = v;
    p.predictedMs = m.timeMs(k, v);
    p.expectedError = m.error(k, v);
    return p;
}

KnobPick chooseKnob(const std::vector<BudgetKnob>& knobs, const std::vector<KnobModel>& models,
                    double budgetMs, double aim, double tolerance) {
    checkBudget(budgetMs);
    if (knobs.empty() || knobs.size() != models.size()) throw UsageError("budget planner: no knob to turn");
    std::optional<KnobPick> best, nearestPick;
    for (std::size_t i = 0; i < knobs.size(); ++i) {
        KnobPick p = fitKnob(knobs[i], models[i], budgetMs);
        p.knob = i;
        const double off = std::abs(p.predictedMs - budgetMs);
        if (off <= aim * budgetMs && (!best || p.expectedError < best->expectedError)) best = p;
        if (!nearestPick || off < std::abs(nearestPick->predictedMs - budgetMs)) nearestPick = p;
    }
    if (best) return *best;
    if (std::abs(nearestPick->predictedMs - budgetMs) <= tolerance * budgetMs) return *nearestPick;
    std::ostringstream os;
    os << "render.budget_ms " << budgetMs << " cannot be met within " << fixed(100 * tolerance, 0) << "%:";
    for (std::size_t i = 0; i < knobs.size(); ++i) {
        const BudgetKnob& k = knobs[i];
        os << (i ? "," : "") << " " << k.name << " " << value(k, fastEnd(k)) << ".." << value(k, slowEnd(k))
           << " (" << k.route << ") takes " << sci(models[i].timeMs(k, fastEnd(k))) << ".."
           << sci(models[i].timeMs(k, slowEnd(k))) << " ms";
    }
    throw UsageError(os.str());
}

std::string BudgetChoice::text() const {
    std::ostringstream os;
    os << "budget " << fixed(budgetMs, 1) << " ms: " << knob << " " << std::setprecision(4) << value << " ("
       << route << "), predicted " << fixed(predictedMs, 1) << " ms, measured " << fixed(measuredMs, 1)
       << " ms (" << percent(measuredMs, budgetMs) << ")\n";
    os << "  expected error: RMSE " << sci(expectedError) << " against " << reference << " = "
       << (biasMeasured ? "route bias " + sci(biasError) : "route bias not measured") << " (+) " << knob
       << " error " << sci(knobError) << '\n';
    for (const auto& o : others)
        os << "  instead: " << o << '\n';
    for (const auto& n : notes)
        os << "  " << n << '\n';
    return os.str();
}

BudgetChoice fitBudget(VolumeRenderer& r, double budgetMs, const std::vector<BudgetKnob>& knobs, int runs) {
    checkBudget(budgetMs);
    if (knobs.empty()) throw UsageError("budget planner: no knob to turn");
    const Scene base = r.scene();
    BudgetChoice c;
    c.budgetMs = budgetMs;

    // Calibration: two probe frames per knob give its time law and its own error law.
    std::vector<Scene> routes;
    std::vector<KnobModel> models(knobs.size());
    std::vector<std::vector<Probe>> measured(knobs.size());
    std::vector<std::array<ImageBuffer, 2>> images(knobs.size());
    for (std::size_t i = 0; i < knobs.size(); ++i) {
        const BudgetKnob& k = knobs[i];
        Scene s = base;
        k.enter(s);
        routes.push_back(s);
        const std::array<double, 2> v{k.probe0, k.probe1};
        for (int j = 0; j < 2; ++j) {
            Scene p = s;
            k.set(p, v[j]);
            if (k.error == KnobError::MonteCarlo) k.reseed(p, j);
            measured[i].push_back({v[j], timeFrames(r, p, runs, &images[i][j])});
            c.probes.push_back({k.name, v[j], measured[i].back().ms});
            c.notes.push_back("probe " + k.name + " " + value(k, v[j]) + ": " +
                              fixed(measured[i].back().ms, 2) + " ms");
        }
        fitTime(k, measured[i][0], measured[i][1], models[i]);
        const double d = imageRmse(images[i][0], images[i][1]), p = k.errorExponent;
        const double spread = k.error == KnobError::MonteCarlo
                                  ? std::sqrt(std::pow(v[0], 2 * p) + std::pow(v[1], 2 * p))
                                  : std::abs(std::pow(v[1], p) - std::pow(v[0], p));
        models[i].C = spread > 0.0 ? d / spread : 0.0;
    }
    // Bias: every deterministic route against the pooled probes of the first Monte Carlo route (its own noise
    // and the route's discretisation error at the probe removed in quadrature).
    const auto mc = std::find_if(knobs.begin(), knobs.end(),
                                 [](const BudgetKnob& k) { return k.error == KnobError::MonteCarlo; });
    c.reference = "the converged image of this route";
    if (mc != knobs.end()) {
        const std::size_t m = std::size_t(mc - knobs.begin());
        const double n = mc->probe0 + mc->probe1;
        const ImageBuffer ref = pooled(images[m][0], mc->probe0, images[m][1], mc->probe1);
        const double refNoise = models[m].knobError(*mc, n);
        c.reference = "the converged " + mc->route + " image";
        for (std::size_t i = 0; i < knobs.size(); ++i) {
            models[i].biasMeasured = true;
            if (i == m) continue;
            const double d = imageRmse(images[i][0], ref), e = models[i].knobError(knobs[i], knobs[i].probe0);
            models[i].bias = std::sqrt(std::max(0.0, d * d - refNoise * refNoise - e * e));
            c.notes.push_back(knobs[i].route + " against " + value(*mc, n) + " pooled " + mc->name +
                              ": RMSE " + sci(d) + ", bias " + sci(models[i].bias));
        }
    }

    // Choice, then measured corrections: refit the chosen knob's time law to all its frames and choose again
    // (possibly another knob) until a frame lands within 5%; if none does after three corrections, the final
    // weighted least-squares choice is measured once more. The kept frame is the last one measured, never the
    // luckiest of several (that one would owe its closeness to noise).
    KnobPick pick = chooseKnob(knobs, models, budgetMs);
    struct Try {
        KnobPick pick;
        double ms;
    };
    std::vector<Try> tries;
    auto measure = [&](const KnobPick& p) {
        const BudgetKnob& k = knobs[p.knob];
        Scene s = routes[p.knob];
        k.set(s, p.value);
        const double ms = timeFrames(r, s, runs);
        tries.push_back({p, ms});
        measured[p.knob].push_back({p.value, ms});
        c.notes.push_back("try " + k.name + " " + value(k, p.value) + ": predicted " +
                          fixed(p.predictedMs, 2) + " ms, measured " + fixed(ms, 2) + " ms");
        return std::abs(ms - budgetMs) <= 0.05 * budgetMs;
    };
    auto refit = [&] {
        const BudgetKnob& k = knobs[pick.knob];
        fitTimeAll(k, withoutSlowedFrames(k, measured[pick.knob], budgetMs), budgetMs, models[pick.knob]);
        try {
            return chooseKnob(knobs, models, budgetMs);
        } catch (const UsageError&) {
            return pick; // the refit says unreachable: keep the frames measured so far
        }
    };
    bool landed = measure(pick);
    for (int it = 0; it < 3 && !landed; ++it) {
        const KnobPick next = refit();
        if (next.knob == pick.knob && next.value == pick.value) break;
        pick = next;
        landed = measure(pick);
    }
    if (!landed) {
        const KnobPick next = refit();
        if (next.knob != pick.knob || next.value != pick.value) measure(pick = next);
    }
    const Try best = tries.back();
    if (best.ms > (1.0 + kBudgetTolerance) * budgetMs)
        refuseIfFastestTooSlow(r, routes, knobs, budgetMs, runs);
    const BudgetKnob& k = knobs[best.pick.knob];
    const KnobModel& model = models[best.pick.knob];
    Scene chosen = routes[best.pick.knob];
    k.set(chosen, best.pick.value);
    r.setScene(chosen); // the chosen frame, with the scene's own seed
    c.knob = k.name;
    c.route = k.route;
    c.value = best.pick.value;
    c.predictedMs = best.pick.predictedMs;
    c.measuredMs = best.ms;
    c.expectedError = model.error(k, c.value);
    c.biasError = model.bias;
    c.knobError = model.knobError(k, c.value);
    c.biasMeasured = model.biasMeasured;
    for (std::size_t i = 0; i < knobs.size(); ++i) {
        if (i == best.pick.knob) continue;
        const KnobPick o = fitKnob(knobs[i], models[i], budgetMs);
        const bool inWindow = std::abs(o.predictedMs - budgetMs) <= 0.1 * budgetMs;
        c.others.push_back(knobs[i].name + " " + value(knobs[i], o.value) + " (" + knobs[i].route +
                           "): predicted " + fixed(o.predictedMs, 1) + " ms (" +
                           percent(o.predictedMs, budgetMs) + "), expected RMSE " + sci(o.expectedError) +
                           (inWindow ? "" : ", not within 10% of the budget"));
    }
    const double vMin = std::min(k.probe0, k.probe1), vMax = std::max(k.probe0, k.probe1);
    if (c.value < 0.25 * vMin || c.value > 4.0 * vMax)
        c.notes.push_back(k.name + " error extrapolated from probes at " + value(k, vMin) + ".." +
                          value(k, vMax) + ": far outside them the power law is only a trend");
    if (!c.met())
        c.notes.push_back("measured " + percent(c.measuredMs, budgetMs) +
                          ": frame times moved while planning (the machine's load)");
    return c;
}

} // namespace volcl
