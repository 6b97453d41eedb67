// Secant search on log2 of the base quantiser step.
#include "wavelet/rate/StepSearch.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl::codec {

// Secant steps between the nearest trials on either side of the window (bisection when a step would
// leave the bracket) reach it in 3-5 trials where bisection from a guess took 8-11.
SearchOutcome runStepSearch(LossyFrame& f, const StepSearch& s) {
    const double range = f.range();
    const double aim = 0.5 * (s.wlo + s.whi);
    auto g = [&s](double q) { return s.logScale ? std::log(std::max(q, 1e-12)) : q; };
    double lo = s.guess - 40, hi = s.guess + 40, qlo = 0, qhi = 0;
    bool haveLo = false, haveHi = false;
    double bestX = 0, prevX = 0, prevQ = 0;
    bool havePrev = false;
    SearchOutcome out;
    double x = range == 0 ? s.guess + 8 : s.guess; // a constant volume meets any PSNR
    for (int it = 0; it < 30; ++it) {
        f.setDelta(std::exp2(x));
        Trial tr;
        BrickPayloads payloads;
        double q = 0;
        const bool ok = s.measure(tr, payloads, q);
        if (ok && (!out.found || (s.keepLargest ? x > bestX : x < bestX))) {
            out.found = true;
            bestX = x;
            out.best = std::move(tr);
            out.steps = f.header().steps;
            out.delta = f.lastDelta();
            out.payloads = std::move(payloads);
        }
        if (range == 0 || (q >= s.wlo && q <= s.whi)) break;
        if (q > s.whi) {
            lo = x;
            qlo = q;
            haveLo = true;
        } else {
            hi = x;
            qhi = q;
            haveHi = true;
        }
        if (hi - lo < 0.02) break;
        double next;
        if (haveLo && haveHi) {
            // Interpolate inside the bracket (bisect next to an exact trial), away from its ends so that it
            // keeps shrinking.
            next =
                std::isfinite(qlo) ? lo + (g(qlo) - g(aim)) * (hi - lo) / (g(qlo) - g(qhi)) : 0.5 * (lo + hi);
            const double margin = 0.05 * (hi - lo);
            next = std::clamp(next, lo + margin, hi - margin);
        } else {
            if (std::isfinite(q) && havePrev && std::isfinite(prevQ) && prevQ != q) {
                next = x + (g(aim) - g(q)) * (x - prevX) / (g(q) - g(prevQ));
            } else {
                // First step or an exact (infinite PSNR) trial.
                next = std::isfinite(q) ? x + (g(aim) - g(q)) / s.slope : x + 2;
            }
            next = std::clamp(next, lo + 0.01, hi - 0.01);
        }
        prevX = x;
        prevQ = q;
        havePrev = true;
        x = next;
    }
    return out;
}

} // namespace volcl::codec
