// The bpv strategy: the smallest base step whose file fits the bit budget (within 1 % below); its trials
// only entropy code (no reconstruction) and the kept trial's payloads are reused.
#include "wavelet/Codec.hpp"
#include "wavelet/rate/StepSearch.hpp"
#include "wavelet/rate/Strategies.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace volcl::codec {

namespace {

class BpvStrategy final : public LossyStrategy {
public:
    using LossyStrategy::LossyStrategy;

protected:
    // log(size) falls about 0.5 per doubling of the step.
    StepChoice search(LossyFrame& f) override {
        const double target = options().target, range = f.range();
        StepSearch s;
        s.guess = std::log2(std::max(range, 1e-30)) - 2 * target;
        s.wlo = 0.99 * target;
        s.whi = target;
        s.logScale = true;
        s.slope = -0.5;
        s.measure = [&](Trial& tr, BrickPayloads& payloads, double& q) {
            tr = f.trial(std::nullopt, false);
            q = double(f.codedBytes(tr, &payloads)) * 8 / f.voxels();
            return q <= target;
        };
        SearchOutcome o = runStepSearch(f, s);
        if (!o.found)
            throw UsageError("--bpv " + std::to_string(target) +
                             " is below what this volume can be coded in");
        f.setSteps(std::move(o.steps));
        if (options().measureError) o.best = f.trial(std::nullopt);
        StepChoice c{std::move(o.best), o.delta, std::move(o.payloads)};
        if (keepFinite(f, c) && double(f.codedBytes(c.best, &c.payloads)) * 8 / f.voxels() > target)
            throw UsageError("--bpv " + std::to_string(target) +
                             " is below what this volume can be coded in (its voxels near the float limit "
                             "reconstruct beyond it unless stored exactly)");
        return c;
    }

    void refine(LossyFrame& f, StepChoice& c, const ResidualTarget*) override { keepFinite(f, c); }

private:
    // Voxels near FLT_MAX can reconstruct beyond float's range at a coarse step; those few are stored
    // exactly, so a decoded volume is never Inf where the input was finite. True when some were.
    static bool keepFinite(LossyFrame& f, StepChoice& c) {
        if (!(f.maxMagnitude() > kOverflowRisk)) return false;
        Trial tr = f.trial(std::numeric_limits<double>::max());
        for (const auto& brick : tr.corrections)
            if (!brick.empty()) {
                c.best = std::move(tr);
                c.payloads.clear();
                return true;
            }
        return false;
    }
    // Magnitudes from which the synthesis sums of a coarse reconstruction can pass FLT_MAX (3.4e38).
    static constexpr double kOverflowRisk = 1e36;
};

} // namespace

std::unique_ptr<RateStrategy> makeBpvStrategy(ComputeContext& cc, const CodecOptions& o,
                                              ValueRangeCache& ranges) {
    return std::make_unique<BpvStrategy>(cc, o, ranges);
}

} // namespace volcl::codec
