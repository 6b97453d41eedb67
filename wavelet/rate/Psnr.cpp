// The psnr strategy: the largest base step whose reconstruction meets the PSNR target (within 0.25 dB above).
#include "wavelet/quantise/Quantiser.hpp"
#include "wavelet/rate/StepSearch.hpp"
#include "wavelet/rate/Strategies.hpp"

#include <algorithm>
#include <cmath>

namespace volcl::codec {

namespace {

class PsnrStrategy final : public LossyStrategy {
public:
    using LossyStrategy::LossyStrategy;

protected:
    // PSNR is close to linear in log2(step), dropping about 6 dB per doubling.
    StepChoice search(LossyFrame& f) override {
        const double target = options().target, range = f.range();
        StepSearch s;
        s.guess = std::log2(std::max(range, 1e-30) * std::pow(10.0, -target / 20) * 3.0);
        s.wlo = target;
        s.whi = target + 0.25;
        s.slope = -6.02;
        s.keepLargest = true;
        s.measure = [&](Trial& tr, BrickPayloads&, double& q) {
            tr = f.trial(std::nullopt);
            q = f.psnrOf(tr);
            return range == 0 || q >= target;
        };
        SearchOutcome o = runStepSearch(f, s);
        if (!o.found) {
            // No step meets the target (magnitudes too small for the float quantiser, or beyond the float
            // transform's range).
            const double bound = exactBeyond(f);
            f.setDelta(bound);
            o.best = f.trial(bound);
            o.steps = f.header().steps;
            o.delta = f.lastDelta();
        }
        f.setSteps(std::move(o.steps));
        return {std::move(o.best), o.delta, {}};
    }

    // A frame at the series' steps: a residual's dead-zone edge is tuned (refineDeadZone). A frame still below
    // the floor (target - kPsnrToleranceDb) makes the series be coded again at a finer step, unless no step
    // can resolve it (magnitudes near the smallest step, or coefficients beyond the float transform's range):
    // its voxels beyond exactBeyond are then stored exactly.
    void refine(LossyFrame& f, StepChoice& c, const ResidualTarget* residual) override {
        if (f.range() == 0) return;
        if (residual) refineDeadZone(f, c);
        const bool unresolvable = f.overflowed() || exactBeyond(f) < kMinStep * 0x1p10;
        if (unresolvable && f.psnrOf(c.best) < options().target - kPsnrToleranceDb)
            c.best = f.trial(exactBeyond(f));
    }

    // Every voxel within E = range * 10^(-target / 20) of the input, the others stored exactly, bounds the MSE
    // by E^2: the PSNR is then at least the target.
    double exactBeyond(const LossyFrame& f) const {
        return f.range() * std::pow(10.0, -options().target / 20);
    }

    // A residual at the series' steps: its dead-zone edge is moved where the plain edge misses the window the
    // series' frames are held to. A prediction that leaves little to code ends above the target: a wider
    // dead zone drops the coefficients that buy the least until the frame just meets the target, as the
    // first frame's step search does. A residual of many coefficients near one step can end below the floor,
    // which would make the whole series be coded again finer: a narrower dead zone keeps them until the frame
    // is back at the floor + kPsnrRecoveryMarginDb. In between, the plain edge is kept (an I frame at the
    // series' steps gets no more). The decoder is unaffected.
    void refineDeadZone(LossyFrame& f, StepChoice& c) {
        const double plain = f.psnrOf(c.best), floor = options().target - kPsnrToleranceDb;
        if (plain >= floor && plain < options().target) return;
        const bool widen = plain >= options().target;
        const double want = widen ? options().target : floor + kPsnrRecoveryMarginDb;
        auto psnrAt = [&](double edge, Trial& tr) {
            f.setZeroBelow(edge);
            tr = f.trial(std::nullopt);
            return f.psnrOf(tr);
        };
        // Bracket [lo, hi] of edges: lo meets `want` (or is the narrowest tried), hi does not.
        double lo = 1, hi = kWidestEdge, keptEdge = 1;
        Trial keep = std::move(c.best);
        if (widen) {
            Trial tr;
            if (psnrAt(hi, tr) >= want) {
                c.best = std::move(tr);
                return;
            }
        } else {
            Trial tr;
            hi = 1;
            lo = kNarrowestEdge;
            const double narrowest = psnrAt(lo, tr);
            keep = std::move(tr);
            keptEdge = lo;
            if (narrowest < want) { // the narrowest edge is the best this step can do
                c.best = std::move(keep);
                return;
            }
        }
        for (int i = 0; i < 6; ++i) {
            const double mid = 0.5 * (lo + hi);
            Trial tr;
            if (psnrAt(mid, tr) >= want) {
                lo = mid;
                keep = std::move(tr);
                keptEdge = mid;
            } else {
                hi = mid;
            }
        }
        f.setZeroBelow(keptEdge);
        c.best = std::move(keep);
    }

    // The dead-zone edges tried, in steps. 0.75 is halfway between the reconstructions of 0 and +-1 (1.5
    // steps): a narrower edge adds error as well as bits, so the error no longer falls with the edge. Beyond
    // 4 little is left to drop.
    static constexpr double kNarrowestEdge = 0.75, kWidestEdge = 4;
};

} // namespace

std::unique_ptr<RateStrategy> makePsnrStrategy(ComputeContext& cc, const CodecOptions& o,
                                               ValueRangeCache& ranges) {
    return std::make_unique<PsnrStrategy>(cc, o, ranges);
}

} // namespace volcl::codec
