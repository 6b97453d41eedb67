// The max-error strategy: every voxel within E of the input; voxels the quantiser leaves outside the bound
// are stored exactly, so the search keeps the candidate step with the smallest file.
#include "wavelet/rate/LossyFrame.hpp"
#include "wavelet/rate/Strategies.hpp"

#include <limits>

namespace volcl::codec {

namespace {

class MaxErrorStrategy final : public LossyStrategy {
public:
    using LossyStrategy::LossyStrategy;

protected:
    // Larger steps leave more voxels to store exactly: keep the candidate with the smallest file.
    StepChoice search(LossyFrame& f) override {
        const double target = options().target;
        StepChoice c;
        std::size_t bestBytes = std::numeric_limits<std::size_t>::max();
        std::vector<double> bestSteps;
        for (double k : {0.9, 1.4, 2.0, 2.8}) {
            f.setDelta(k * target);
            Trial tr = f.trial(target);
            const std::size_t bytes = f.codedBytes(tr, nullptr);
            if (bytes < bestBytes) {
                bestBytes = bytes;
                c.best = std::move(tr);
                bestSteps = f.header().steps;
                c.delta = f.lastDelta();
            }
        }
        f.setSteps(std::move(bestSteps));
        return c;
    }
};

} // namespace

std::unique_ptr<RateStrategy> makeMaxErrorStrategy(ComputeContext& cc, const CodecOptions& o,
                                                   ValueRangeCache& ranges) {
    return std::make_unique<MaxErrorStrategy>(cc, o, ranges);
}

} // namespace volcl::codec
