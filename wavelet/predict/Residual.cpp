// Prediction rounding, residuals and reconstruction of predicted frames.
#include "wavelet/predict/Residual.hpp"

#include "core/Error.hpp"

namespace volcl::codec {

Volume quantisedPrediction(const Volume& prediction, ScalarType frameType) {
    if (prediction.type() != ScalarType::Float32) throw Error("internal: a prediction is Float32");
    Volume out = prediction;
    if (frameType == ScalarType::Float32) return out;
    const Volume typeOnly({1, 1, 1}, frameType); // selects the voxel type for the rounding
    visitTyped(typeOnly, [&](auto t) {
        using V = typename decltype(t)::element_type;
        const auto p = prediction.values<float>();
        auto o = out.values<float>();
        for (std::size_t i = 0; i < p.size(); ++i)
            o[i] = static_cast<float>(toVoxel<V>(p[i]));
    });
    return out;
}

Volume residualOf(const Volume& frame, const Volume& prediction) {
    Volume r(frame.dims(), ScalarType::Float32);
    const auto p = prediction.values<float>();
    auto o = r.values<float>();
    visitTyped(frame, [&](auto f) {
        for (std::size_t i = 0; i < f.size(); ++i)
            o[i] = static_cast<float>(f[i]) - p[i];
    });
    r.spacing = frame.spacing;
    r.origin = frame.origin;
    return r;
}

Volume addResidual(const Volume& prediction, const Volume& residual, ScalarType frameType) {
    Volume out(prediction.dims(), frameType);
    out.spacing = residual.spacing;
    out.origin = residual.origin;
    const auto p = prediction.values<float>(), r = residual.values<float>();
    visitTyped(out, [&](auto o) {
        using V = typename decltype(o)::element_type;
        for (std::size_t i = 0; i < o.size(); ++i)
            o[i] = predictedVoxel<V>(p[i], r[i]);
    });
    return out;
}

} // namespace volcl::codec
