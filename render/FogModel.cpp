// Fog resolved against a renderer's data: box, up, height map, point extinction and kernel parameters.
#include "render/FogModel.hpp"

#include "core/Error.hpp"
#include "host/image/ImageIo.hpp"
#include "render/VecMath.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl {

FogField::FogField(const FogEffect& fog, const WorldBox& volumeBox)
    : fog_(fog), box_(fog.box ? *fog.box : volumeBox), up_(normalized(fog.up)) {
    if (fog.heightMap.empty()) return;
    int upAxis = 0;
    for (int a = 0; a < 3; ++a)
        if (fog.up[a] != 0.0) upAxis = a;
    axis0_ = upAxis == 0 ? 1 : 0;
    axis1_ = upAxis == 2 ? 1 : 2;
    const ImageBuffer img = readImage(fog.heightMap);
    if (img.width < 1 || img.height < 1 || img.channelCount() < 1)
        throw DataError(fog.heightMap.string() + ": fog height map is empty");
    // Heights along up: the box's extent (up may point down an axis).
    const double lo = dot(box_.origin, up_), hi = dot(box_.hi(), up_);
    const std::array<double, 2> range =
        fog.heightRange ? *fog.heightRange : std::array<double, 2>{std::min(lo, hi), std::max(lo, hi)};
    mapW_ = img.width;
    mapH_ = img.height;
    map_.resize(std::size_t(mapW_) * std::size_t(mapH_));
    const int nc = img.channelCount();
    for (std::size_t i = 0; i < map_.size(); ++i) {
        const float v = img.pixels[i * std::size_t(nc)];
        if (!std::isfinite(v))
            throw DataError(fog.heightMap.string() + ": fog height map has a NaN/Inf texel at (" +
                            std::to_string(i % std::size_t(mapW_)) + ", " +
                            std::to_string(i / std::size_t(mapW_)) + ")");
        map_[i] = static_cast<float>(range[0] + double(v) * (range[1] - range[0]));
    }
}

double FogField::baseAt(const Vec3& p) const {
    if (map_.empty()) return fog_.base;
    auto texel = [&](int axis, int n) {
        const double e = box_.extent[axis];
        const double f = e > 0.0 ? (p[axis] - box_.origin[axis]) / e * double(n) : 0.0;
        return std::clamp(int(std::floor(f)), 0, n - 1);
    };
    return map_[std::size_t(texel(axis1_, mapH_)) * std::size_t(mapW_) + std::size_t(texel(axis0_, mapW_))];
}

double FogField::extinction(const Vec3& p) const {
    const Vec3 hi = box_.hi();
    for (int a = 0; a < 3; ++a)
        if (p[a] < box_.origin[a] || p[a] > hi[a]) return 0.0;
    const double dh = dot(p, up_) - baseAt(p);
    if (dh <= 0.0) return fog_.density;
    if (fog_.falloff == 0.0) return 0.0;
    return fog_.density * std::exp(-dh / fog_.falloff);
}

bool FogField::clip(const Vec3& o, const Vec3& d, double& t0, double& t1) const {
    const Vec3 hi = box_.hi();
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0.0) {
            if (o[a] < box_.origin[a] || o[a] > hi[a]) return false;
        } else {
            const double u = (box_.origin[a] - o[a]) / d[a], v = (hi[a] - o[a]) / d[a];
            t0 = std::max(t0, std::min(u, v));
            t1 = std::min(t1, std::max(u, v));
        }
    }
    return t1 > t0;
}

VolclFogParams FogField::params() const {
    VolclFogParams p{};
    const Vec3 hi = box_.hi();
    for (int i = 0; i < 3; ++i) {
        p.up[i] = float(up_[i]);
        p.color[i] = float(fog_.color[i]);
        p.lo[i] = float(box_.origin[i]);
        p.hi[i] = float(hi[i]);
    }
    p.up[3] = float(fog_.base);
    p.color[3] = float(fog_.density);
    // 1 / falloff: -1 marks falloff 0 (no fog above the base); a falloff so large its inverse is below
    // float's normal range is infinite (constant fog).
    p.lo[3] = fog_.falloff == 0.0 ? -1.0f : float(1.0 / fog_.falloff);
    p.mapAxis[0] = volcl_uint(axis0_);
    p.mapAxis[1] = volcl_uint(axis1_);
    p.mapSize[0] = volcl_uint(std::max(mapW_, 1));
    p.mapSize[1] = volcl_uint(std::max(mapH_, 1));
    return p;
}

} // namespace volcl
