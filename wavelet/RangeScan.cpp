// Value-range scans of the codec on host threads.
#include "wavelet/RangeScan.hpp"

#include "core/runtime/ParallelFor.hpp"
#include "wavelet/BrickVoxels.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl::codec {

ValueRange valueRange(const Volume& v, unsigned threads) {
    constexpr std::size_t kParts = 16;
    struct Part {
        double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();
        bool nonFinite = false;
    };
    std::vector<Part> parts(kParts);
    const std::size_t n = v.voxelCount();
    visitTyped(v, [&](auto span) {
        using S = std::remove_const_t<typename decltype(span)::element_type>;
        parallelFor(kParts, threads, [&](std::size_t p) {
            const std::size_t b = n * p / kParts, e = n * (p + 1) / kParts;
            if (b == e) return;
            if constexpr (std::is_same_v<S, float>) {
                float lo = std::numeric_limits<float>::infinity(), hi = -lo;
                bool bad = false;
                for (std::size_t i = b; i < e; ++i) {
                    const float x = span[i];
                    if (!std::isfinite(x)) {
                        bad = true;
                        continue;
                    }
                    lo = std::min(lo, x);
                    hi = std::max(hi, x);
                }
                parts[p] = {lo, hi, bad};
            } else {
                S lo = span[b], hi = span[b];
                for (std::size_t i = b; i < e; ++i) {
                    const S x = span[i]; // value selects vectorise; std::min on references did not
                    lo = x < lo ? x : lo;
                    hi = x > hi ? x : hi;
                }
                parts[p] = {double(lo), double(hi), false};
            }
        });
    });
    ValueRange r;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Part& p : parts) {
        lo = std::min(lo, p.lo);
        hi = std::max(hi, p.hi);
        r.nonFinite = r.nonFinite || p.nonFinite;
    }
    if (lo <= hi) {
        r.min = lo;
        r.max = hi;
    }
    return r;
}

std::vector<std::pair<double, double>> brickRanges(const Volume& v, const VczHeader& h, unsigned threads) {
    std::vector<std::pair<double, double>> r(h.brickCount());
    parallelFor(r.size(), threads, [&](std::size_t b) {
        const auto vox = brickVoxels<double>(v, h, b);
        double lo = std::numeric_limits<double>::infinity(), hi = -lo;
        for (double x : vox)
            if (std::isfinite(x)) {
                lo = std::min(lo, x);
                hi = std::max(hi, x);
            }
        if (lo > hi) lo = hi = 0;
        r[b] = {lo, hi};
    });
    return r;
}

} // namespace volcl::codec
