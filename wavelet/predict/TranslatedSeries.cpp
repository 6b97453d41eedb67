// Synthetic motion: separable Keys-cubic translation of a volume, one shift per frame.
#include "wavelet/predict/TranslatedSeries.hpp"

#include "core/Error.hpp"
#include "wavelet/predict/GlobalShift.hpp"

#include <cmath>

namespace volcl {

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
            keysShiftAxis(v, d, a, double(k) * shiftPerFrame[std::size_t(a)]);
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
