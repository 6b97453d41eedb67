// The bpv strategy: the smallest base step whose file fits the bit budget (within 1 % below); its trials
// only entropy code (no reconstruction) and the kept trial's payloads are reused.
#include "wavelet/Codec.hpp"
#include "wavelet/rate/StepSearch.hpp"
#include "wavelet/rate/Strategies.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>
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
        return {std::move(o.best), o.delta, std::move(o.payloads)};
    }
};

} // namespace

std::unique_ptr<RateStrategy> makeBpvStrategy(ComputeContext& cc, const CodecOptions& o,
                                              ValueRangeCache& ranges) {
    return std::make_unique<BpvStrategy>(cc, o, ranges);
}

} // namespace volcl::codec
