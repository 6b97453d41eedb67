// The psnr strategy: the largest base step whose reconstruction meets the PSNR target (aiming within 0.25 dB above).
#include "wavelet/quantise/Quantiser.hpp"
#include "wavelet/rate/StepSearch.hpp"
#include "wavelet/rate/Strategies.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace volcl::codec {

namespace {

class PsnrStrategy final : public LossyStrategy {
public:
    using LossyStrategy::LossyStrategy;

protected:
    // The step is estimated on a sample of bricks, each sample round 1/kSampleShare of a full one (PSNR is
    // close to linear in log2(step), dropping about 6 dB per doubling), aimed at the middle of the window
    // [target, target + kWindowDb], then checked by a full round, kept when in that window. The sample's PSNR
    // is offset from the frame's by how alike its bricks are to the rest: a full round outside gives the
    // offset, and one correction round at the sample's step for the shifted, narrower window [target +
    // kWindowDb / 5, target + 3 kWindowDb / 5] is kept when it meets the target and is at most 2 kWindowDb
    // above it. Else the full search runs from there.
    StepChoice search(LossyFrame& f) override {
        const double target = options().target, range = f.range();
        const double analytic = std::log2(std::max(range, 1e-30) * std::pow(10.0, -target / 20) * 3.0);
        const std::vector<std::size_t> sample = sampleBricks(f.header());
        std::optional<SearchOutcome> kept;
        double guess = analytic;
        if (range > 0 && !sample.empty()) {
            double sampleVoxels = 0;
            for (std::size_t b : sample)
                sampleVoxels += double(f.header().brickDims(b).count());
            auto samplePsnr = [&](const Trial& tr) {
                const double mse = tr.err.sumSq / sampleVoxels;
                return mse == 0 ? std::numeric_limits<double>::infinity()
                                : 10 * std::log10(range * range / mse);
            };
            // The largest step whose sample PSNR is in [lo, hi], and its sample PSNR.
            auto sampleStep = [&](double lo, double hi,
                                  double from) -> std::optional<std::pair<double, double>> {
                StepSearch s = window(lo, from);
                s.whi = hi;
                s.measure = [&](Trial& tr, BrickPayloads&, double& q) {
                    tr = f.trial(std::nullopt, true, &sample);
                    q = samplePsnr(tr);
                    return q >= lo;
                };
                SearchOutcome o = runStepSearch(f, s);
                // A sample of constant bricks says nothing about the step.
                if (!o.found || !std::isfinite(samplePsnr(o.best))) return std::nullopt;
                return std::pair{std::log2(o.delta), samplePsnr(o.best)};
            };
            // A full round at log2 step x: kept when it meets the target and has the largest step so far.
            auto fullAt = [&](double x) {
                f.setDelta(std::exp2(x));
                SearchOutcome o;
                o.best = f.trial(std::nullopt);
                o.steps = f.header().steps;
                o.delta = f.lastDelta();
                const double q = f.psnrOf(o.best);
                o.found = q >= target;
                if (o.found && (!kept || o.delta > kept->delta)) kept = std::move(o);
                return q;
            };
            if (const auto first = sampleStep(target, target + kWindowDb, analytic)) {
                const double q0 = fullAt(first->first);
                guess = first->first;
                if (q0 < target || q0 > target + kWindowDb) {
                    // An infinite PSNR (the step drops nothing) gives no offset: the sample's was infinite too.
                    const double offset =
                        std::isfinite(q0) && std::isfinite(first->second) ? q0 - first->second : 0;
                    if (const auto second = sampleStep(target + kWindowDb / 5 - offset,
                                                       target + 3 * kWindowDb / 5 - offset, first->first)) {
                        guess = second->first;
                        if (second->first != first->first) fullAt(second->first);
                    }
                }
            }
        }
        SearchOutcome o;
        // A kept round far above the window (the estimate missed twice) is refined by the full search.
        if (kept && f.psnrOf(kept->best) <= target + 2 * kWindowDb) {
            o = std::move(*kept);
        } else {
            StepSearch s = window(target, guess);
            s.measure = [&](Trial& tr, BrickPayloads&, double& q) {
                tr = f.trial(std::nullopt);
                q = f.psnrOf(tr);
                return range == 0 || q >= target;
            };
            o = runStepSearch(f, s);
        }
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

    // The search window [target, target + kWindowDb] on PSNR, from log2 step `guess`.
    static StepSearch window(double target, double guess) {
        StepSearch s;
        s.guess = guess;
        s.wlo = target;
        s.whi = target + kWindowDb;
        s.slope = -6.02;
        s.keepLargest = true;
        return s;
    }

    // Bricks spread evenly through the index, about 1/kSampleShare of them: none when the frame has too few
    // bricks for a sample to be cheaper than the full rounds.
    static std::vector<std::size_t> sampleBricks(const VczHeader& h) {
        const std::size_t n = h.brickCount();
        std::vector<std::size_t> out;
        if (n < kMinSampledBricks) return out;
        const std::size_t k = n / kSampleShare;
        for (std::size_t i = 0; i < k; ++i)
            out.push_back((2 * i + 1) * n / (2 * k));
        return out;
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
    // Above the target, the PSNR window a search stops in.
    static constexpr double kWindowDb = 0.25;
    // A sample of 1/8 of the bricks, taken from 32 bricks up (below that a full round costs little).
    static constexpr std::size_t kSampleShare = 8, kMinSampledBricks = 32;
};

} // namespace

std::unique_ptr<RateStrategy> makePsnrStrategy(ComputeContext& cc, const CodecOptions& o,
                                               ValueRangeCache& ranges) {
    return std::make_unique<PsnrStrategy>(cc, o, ranges);
}

} // namespace volcl::codec
