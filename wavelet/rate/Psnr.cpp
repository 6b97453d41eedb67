// The psnr strategy: the largest base step whose reconstruction meets the PSNR target (within 0.25 dB above).
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
            f.setDelta(std::exp2(s.guess - 40));
            o.best = f.trial(std::nullopt);
            o.steps = f.header().steps;
            o.delta = f.lastDelta();
        }
        f.setSteps(std::move(o.steps));
        return {std::move(o.best), o.delta, {}};
    }
};

} // namespace

std::unique_ptr<RateStrategy> makePsnrStrategy(ComputeContext& cc, const CodecOptions& o,
                                               ValueRangeCache& ranges) {
    return std::make_unique<PsnrStrategy>(cc, o, ranges);
}

} // namespace volcl::codec
