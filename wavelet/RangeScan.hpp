// Value-range scans of the codec: a volume's min/max and non-finite check, and per-brick ranges.
#pragma once

#include "core/Volume.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <utility>
#include <vector>

namespace volcl::codec {

// Min and max over the finite voxels and whether any voxel is NaN or Inf, in one typed pass on host threads
// (Volume::stats also builds moments and a histogram, which the codec does not need).
struct ValueRange {
    double min = 0, max = 0;
    bool nonFinite = false;
};
ValueRange valueRange(const Volume& v, unsigned threads);

/// Min and max of each brick over its finite voxels (0, 0 for a brick of NaN/Inf only).
std::vector<std::pair<double, double>> brickRanges(const Volume& v, const VczHeader& h, unsigned threads);

/// One volume's range, scanned on first use (the pipeline and the rate control both need it).
class ValueRangeCache {
public:
    explicit ValueRangeCache(unsigned threads) : threads_(threads) {}
    const ValueRange& of(const Volume& v) {
        if (of_ != &v) {
            range_ = valueRange(v, threads_);
            of_ = &v;
        }
        return range_;
    }

private:
    unsigned threads_;
    const Volume* of_ = nullptr;
    ValueRange range_;
};

} // namespace volcl::codec
