// The bounded strategies (--max-error, --rel-error, --pw-rel-error): every voxel within its bound of the
// input; voxels the quantiser leaves outside it are stored exactly, so the search keeps the candidate step
// with the smallest file.
#include "wavelet/BrickVoxels.hpp"
#include "wavelet/rate/LossyFrame.hpp"
#include "wavelet/rate/Strategies.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace volcl::codec {

namespace {

/// The magnitudes |x| of the finite non-zero voxels at the fractions `p` of their sorted order, from a
/// sample of at most `kSample` voxels (evenly strided); empty when every voxel is zero or non-finite.
template <std::size_t N>
std::vector<double> magnitudeQuantiles(const Volume& v, const std::array<double, N>& p) {
    static constexpr std::size_t kSample = 1 << 20;
    const std::size_t n = v.voxelCount(), stride = std::max<std::size_t>(1, n / kSample);
    std::vector<double> mags;
    mags.reserve(std::min(n, kSample + 1));
    visitTyped(v, [&](auto span) {
        for (std::size_t i = 0; i < n; i += stride) {
            const double a = std::abs(double(span[i]));
            if (a > 0 && std::isfinite(a)) mags.push_back(a);
        }
    });
    std::vector<double> q;
    if (mags.empty()) return q;
    for (double f : p) {
        const auto k = static_cast<std::ptrdiff_t>(f * double(mags.size() - 1));
        std::nth_element(mags.begin(), mags.begin() + k, mags.end());
        q.push_back(mags[std::size_t(k)]);
    }
    return q;
}

class BoundedStrategy final : public LossyStrategy {
public:
    using LossyStrategy::LossyStrategy;

protected:
    std::optional<VoxelBound> voxelBound(const ValueRange& finite) const override {
        const double r = options().target;
        switch (options().rate) {
        case RateMode::RelError:
            return VoxelBound(r * (finite.max - finite.min));
        case RateMode::PwRelError:
            return VoxelBound(0, r);
        default:
            return VoxelBound(r);
        }
    }

    // Larger steps leave more voxels to store exactly: keep the candidate with the smallest file.
    StepChoice search(LossyFrame& f) override {
        const VoxelBound bound = *voxelBound(f.valueRange());
        StepChoice c;
        std::size_t bestBytes = std::numeric_limits<std::size_t>::max();
        std::vector<double> bestSteps;
        for (double delta : candidateSteps(f, bound)) {
            f.setDelta(delta);
            Trial tr = f.trial(bound);
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

private:
    // An absolute bound E: steps around E. A point-wise relative bound R: steps R x |x| at magnitudes from
    // the small to the typical voxel, so the search weighs many exactly stored small voxels (fine steps
    // everywhere) against few (coarse steps, small voxels stored exactly).
    std::vector<double> candidateSteps(const LossyFrame& f, const VoxelBound& bound) const {
        std::vector<double> steps;
        if (bound.relative == 0) {
            // A constant frame (rel-error over a zero range) still needs a positive step.
            const double e = bound.absolute > 0 ? bound.absolute : std::max(f.maxMagnitude(), 1.0) * 1e-7;
            for (double k : {0.9, 1.4, 2.0, 2.8})
                steps.push_back(k * e);
            return steps;
        }
        for (double m : magnitudeQuantiles(f.truth(), std::array{0.02, 0.1, 0.3, 0.6}))
            steps.push_back(1.4 * bound.relative * m);
        if (steps.empty()) steps.push_back(1.0); // all zero (or non-finite): any step reconstructs zeros
        return steps;
    }
};

} // namespace

std::unique_ptr<RateStrategy> makeBoundedStrategy(ComputeContext& cc, const CodecOptions& o,
                                                  ValueRangeCache& ranges) {
    return std::make_unique<BoundedStrategy>(cc, o, ranges);
}

} // namespace volcl::codec
