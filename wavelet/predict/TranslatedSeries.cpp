// Synthetic motion: separable Keys-cubic translation of a volume, one shift per frame.
#include "wavelet/predict/TranslatedSeries.hpp"

#include "host/Error.hpp"

#include <algorithm>
#include <cmath>

namespace volcl {

namespace {

// Keys cubic convolution weights for the four samples around a position with fraction f in [0, 1).
std::array<double, 4> keysWeights(double f) {
    auto k = [](double t) {
        t = std::abs(t);
        if (t < 1) return 1.5 * t * t * t - 2.5 * t * t + 1;
        if (t < 2) return -0.5 * t * t * t + 2.5 * t * t - 4 * t + 2;
        return 0.0;
    };
    return {k(1 + f), k(f), k(1 - f), k(2 - f)};
}

// Resamples `v` along one axis (stride between neighbours `stride`, length n): out[i] = v(i - shift).
void shiftAxis(std::vector<double>& v, Dims d, int axis, double shift) {
    if (shift == 0) return;
    const std::size_t n = axis == 0 ? d.x : axis == 1 ? d.y : d.z;
    const std::size_t stride = axis == 0 ? 1 : axis == 1 ? d.x : d.x * d.y;
    const double start = -shift;
    const double fl = std::floor(start);
    const std::array<double, 4> w = keysWeights(start - fl);
    const long base = static_cast<long>(fl);
    std::vector<double> line(n), out(n);
    for (std::size_t s = 0; s < v.size(); ++s) {
        // s enumerates line starts: the voxels whose coordinate along `axis` is 0.
        const std::size_t coord = (s / stride) % n;
        if (coord != 0) continue;
        for (std::size_t i = 0; i < n; ++i)
            line[i] = v[s + i * stride];
        for (std::size_t i = 0; i < n; ++i) {
            double acc = 0;
            for (int t = 0; t < 4; ++t) {
                const long j = std::clamp<long>(long(i) + base - 1 + t, 0, long(n) - 1);
                acc += w[std::size_t(t)] * line[std::size_t(j)];
            }
            out[i] = acc;
        }
        for (std::size_t i = 0; i < n; ++i)
            v[s + i * stride] = out[i];
    }
}

} // namespace

TimeSeries translatedSeries(const Volume& base, std::size_t frames, std::array<double, 3> shiftPerFrame) {
    if (frames == 0) throw UsageError("a translated series needs at least one frame");
    for (double s : shiftPerFrame)
        if (!std::isfinite(s)) throw UsageError("translation per frame must be finite");
    TimeSeries ts;
    const Dims d = base.dims();
    for (std::size_t k = 0; k < frames; ++k) {
        std::vector<double> v(base.voxelCount());
        for (std::size_t i = 0; i < v.size(); ++i)
            v[i] = base.valueAt(i);
        for (int a = 0; a < 3; ++a)
            shiftAxis(v, d, a, double(k) * shiftPerFrame[std::size_t(a)]);
        Volume f(d, ScalarType::Float32);
        auto fv = f.values<float>();
        for (std::size_t i = 0; i < v.size(); ++i)
            fv[i] = static_cast<float>(v[i]);
        Volume out = base.type() == ScalarType::Float32 ? std::move(f) : f.convertedTo(base.type());
        out.spacing = base.spacing;
        out.origin = base.origin;
        ts.frames.push_back(std::move(out));
    }
    return ts;
}

} // namespace volcl
