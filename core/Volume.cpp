// Volume model implementation: allocation checks, typed access, conversion, cropping and statistics.
#include "core/Volume.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <limits>

namespace volcl {

std::size_t scalarSize(ScalarType t) noexcept {
    switch (t) {
    case ScalarType::UInt8:
        return 1;
    case ScalarType::UInt16:
    case ScalarType::Int16:
        return 2;
    case ScalarType::Float32:
        return 4;
    case ScalarType::Float64:
        return 8;
    }
    return 1;
}

std::string_view scalarTypeName(ScalarType t) noexcept {
    switch (t) {
    case ScalarType::UInt8:
        return "uint8";
    case ScalarType::UInt16:
        return "uint16";
    case ScalarType::Int16:
        return "int16";
    case ScalarType::Float32:
        return "float32";
    case ScalarType::Float64:
        return "float64";
    }
    return "?";
}

ScalarType parseScalarType(std::string_view name) {
    std::string n(name);
    std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (n == "uint8" || n == "u8" || n == "uchar" || n == "unsigned char") return ScalarType::UInt8;
    if (n == "uint16" || n == "u16" || n == "ushort" || n == "unsigned short") return ScalarType::UInt16;
    if (n == "int16" || n == "i16" || n == "short") return ScalarType::Int16;
    if (n == "float32" || n == "float" || n == "f32") return ScalarType::Float32;
    if (n == "float64" || n == "double" || n == "f64") return ScalarType::Float64;
    throw UsageError("unknown scalar type '" + std::string(name) +
                     "' (use uint8, uint16, int16, float32 or float64)");
}

Direction3 orthonormalDirection(const Direction3& m) {
    std::array<std::array<double, 3>, 3> c{};
    for (int col = 0; col < 3; ++col) {
        for (int row = 0; row < 3; ++row)
            c[col][row] = m[std::size_t(3 * row + col)];
        for (int prev = 0; prev < col; ++prev) {
            double d = 0;
            for (int row = 0; row < 3; ++row)
                d += c[col][row] * c[prev][row];
            for (int row = 0; row < 3; ++row)
                c[col][row] -= d * c[prev][row];
        }
        const double len = std::hypot(c[col][0], c[col][1], c[col][2]);
        // Relative to the input column: a column that the others nearly span has no direction of its own.
        const double in = std::hypot(m[std::size_t(col)], m[std::size_t(3 + col)], m[std::size_t(6 + col)]);
        if (!std::isfinite(len) || !(len > 1e-6 * in))
            throw DataError("direction matrix: axis " + std::to_string(col) +
                            " is zero, not finite or dependent on the others");
        for (int row = 0; row < 3; ++row)
            c[col][row] /= len;
    }
    Direction3 out{};
    for (int col = 0; col < 3; ++col)
        for (int row = 0; row < 3; ++row)
            out[std::size_t(3 * row + col)] = c[col][row];
    return out;
}

double determinant(const Direction3& m) noexcept {
    return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
           m[2] * (m[3] * m[7] - m[4] * m[6]);
}

Volume::Volume(Dims dims, ScalarType type) : dims_(dims), type_(type) {
    if (dims.x == 0 || dims.y == 0 || dims.z == 0)
        throw DataError("volume dimensions must be positive, got " + std::to_string(dims.x) + "x" +
                        std::to_string(dims.y) + "x" + std::to_string(dims.z));
    constexpr std::size_t kMax = std::numeric_limits<std::size_t>::max();
    std::size_t s = scalarSize(type);
    if (dims.x > kMax / dims.y || dims.x * dims.y > kMax / dims.z || dims.count() > kMax / s)
        throw DataError("volume dimensions overflow the address space");
    bytes_ = ZeroedBytes(dims.count() * s);
}

void Volume::checkType(ScalarType t) const {
    if (t != type_)
        throw DataError("volume holds " + std::string(scalarTypeName(type_)) + ", accessed as " +
                        std::string(scalarTypeName(t)));
}

namespace {
template <class F> decltype(auto) visitType(ScalarType t, F&& f) {
    switch (t) {
    case ScalarType::UInt8:
        return f(std::uint8_t{});
    case ScalarType::UInt16:
        return f(std::uint16_t{});
    case ScalarType::Int16:
        return f(std::int16_t{});
    case ScalarType::Float64:
        return f(double{});
    case ScalarType::Float32:
        break;
    }
    return f(float{});
}
} // namespace

double Volume::valueAt(std::size_t n) const noexcept {
    return visitType(type_, [&](auto tag) -> double {
        using T = decltype(tag);
        T v;
        std::memcpy(&v, bytes_.data() + n * sizeof(T), sizeof(T));
        return static_cast<double>(v);
    });
}

std::vector<float> Volume::toFloat() const {
    std::vector<float> out(voxelCount());
    visitType(type_, [&](auto tag) {
        using T = decltype(tag);
        auto v = values<T>();
        std::transform(v.begin(), v.end(), out.begin(), [](T x) { return static_cast<float>(x); });
    });
    return out;
}

Volume Volume::convertedTo(ScalarType target) const {
    Volume out(dims_, target);
    out.spacing = spacing;
    out.origin = origin;
    out.direction = direction;
    out.anatomical = anatomical;
    if (target == type_) {
        out.bytes_ = bytes_;
        return out;
    }
    visitType(target, [&](auto tag) {
        using T = decltype(tag);
        auto dst = out.values<T>();
        for (std::size_t n = 0; n < dst.size(); ++n) {
            double v = valueAt(n);
            if constexpr (std::is_same_v<T, float>) {
                // Finite float64 values beyond float's range clamp to +/-FLT_MAX (a cast would be undefined);
                // NaN and Inf stay NaN and Inf.
                constexpr double kMax = std::numeric_limits<float>::max();
                dst[n] =
                    std::isfinite(v) ? static_cast<float>(std::clamp(v, -kMax, kMax)) : static_cast<float>(v);
            } else if constexpr (std::is_floating_point_v<T>) {
                dst[n] = static_cast<T>(v);
            } else {
                // NaN has no integer value: it becomes 0 rather than undefined behaviour.
                double lo = std::numeric_limits<T>::min(), hi = std::numeric_limits<T>::max();
                dst[n] = std::isnan(v) ? T(0) : static_cast<T>(std::clamp(std::nearbyint(v), lo, hi));
            }
        }
    });
    return out;
}

Volume Volume::cropped(Dims lo, Dims hi) const {
    if (!(lo.x < hi.x && lo.y < hi.y && lo.z < hi.z && hi.x <= dims_.x && hi.y <= dims_.y && hi.z <= dims_.z))
        throw UsageError("crop box " + std::to_string(lo.x) + "," + std::to_string(lo.y) + "," +
                         std::to_string(lo.z) + ":" + std::to_string(hi.x) + "," + std::to_string(hi.y) +
                         "," + std::to_string(hi.z) + " is empty or outside the volume " +
                         std::to_string(dims_.x) + "x" + std::to_string(dims_.y) + "x" +
                         std::to_string(dims_.z));
    Volume out({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}, type_);
    out.spacing = spacing;
    out.direction = direction;
    out.anatomical = anatomical;
    // The crop's first voxel in world: origin + D diag(spacing) lo (D turns index axes into world axes).
    for (int r = 0; r < 3; ++r) {
        double offset = 0.0;
        for (int c = 0; c < 3; ++c)
            offset += direction[std::size_t(r * 3 + c)] * double((&lo.x)[c]) * spacing[std::size_t(c)];
        out.origin[std::size_t(r)] = origin[std::size_t(r)] + offset;
    }
    std::size_t s = scalarSize(type_), row = out.dims_.x * s;
    for (std::size_t k = 0; k < out.dims_.z; ++k)
        for (std::size_t j = 0; j < out.dims_.y; ++j)
            std::memcpy(out.bytes_.data() + out.index(0, j, k) * s,
                        bytes_.data() + index(lo.x, lo.y + j, lo.z + k) * s, row);
    return out;
}

VolumeStats Volume::stats(std::size_t histogramBins) const {
    VolumeStats st;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo, sum = 0.0, sum2 = 0.0;
    std::size_t finite = 0;
    for (std::size_t n = 0; n < voxelCount(); ++n) {
        double v = valueAt(n);
        if (std::isnan(v)) {
            ++st.nanCount;
            continue;
        }
        if (std::isinf(v)) {
            ++st.infCount;
            continue;
        }
        lo = std::min(lo, v);
        hi = std::max(hi, v);
        sum += v;
        sum2 += v * v;
        ++finite;
    }
    if (finite == 0) return st;
    st.min = lo;
    st.max = hi;
    st.mean = sum / double(finite);
    st.stddev = std::sqrt(std::max(0.0, sum2 / double(finite) - st.mean * st.mean));
    st.histogram.assign(std::max<std::size_t>(histogramBins, 1), 0);
    double width = hi > lo ? (hi - lo) / double(st.histogram.size()) : 1.0;
    for (std::size_t n = 0; n < voxelCount(); ++n) {
        double v = valueAt(n);
        if (!std::isfinite(v)) continue;
        auto b = static_cast<std::size_t>((v - lo) / width);
        ++st.histogram[std::min(b, st.histogram.size() - 1)];
    }
    return st;
}

bool Volume::sameGrid(const Volume& o) const noexcept {
    return dims_ == o.dims_ && type_ == o.type_ && spacing == o.spacing && origin == o.origin &&
           direction == o.direction;
}

void TimeSeries::validate() const {
    if (frames.empty()) throw DataError("time series has no frames");
    for (std::size_t i = 1; i < frames.size(); ++i)
        if (!frames[i].sameGrid(frames[0]))
            throw DataError("time series frame " + std::to_string(i) +
                            " is on a different grid than frame 0");
    if (!times.empty() && times.size() != frames.size())
        throw DataError("time series has " + std::to_string(times.size()) + " time values for " +
                        std::to_string(frames.size()) + " frames");
}

} // namespace volcl
