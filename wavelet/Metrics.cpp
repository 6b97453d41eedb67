// Error metrics between two volumes.
#include "wavelet/Metrics.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl {

namespace {
template <class Fn> void forEachPair(const Volume& a, const Volume& b, Fn fn) {
    if (a.dims() != b.dims()) throw UsageError("volumes differ in dimensions: cannot compare");
    for (std::size_t i = 0; i < a.voxelCount(); ++i)
        fn(a.valueAt(i), b.valueAt(i));
}
} // namespace

double maxAbsError(const Volume& a, const Volume& b) {
    double m = 0;
    forEachPair(a, b, [&](double x, double y) { m = std::max(m, std::abs(x - y)); });
    return m;
}

double rmse(const Volume& a, const Volume& b) {
    double s = 0;
    forEachPair(a, b, [&](double x, double y) { s += (x - y) * (x - y); });
    return std::sqrt(s / double(a.voxelCount()));
}

double psnr(const Volume& a, const Volume& b) {
    const double e = rmse(a, b);
    const VolumeStats st = a.stats(1);
    if (e == 0) return std::numeric_limits<double>::infinity();
    if (st.max == st.min) return std::numeric_limits<double>::quiet_NaN();
    return 20 * std::log10((st.max - st.min) / e);
}

} // namespace volcl
