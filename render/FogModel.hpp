// Fog resolved against a renderer's data: its box, unit up and height map, the extinction at a point (for
// the double references) and the kernel parameters (cl/common/fog.h).
#pragma once

#include "cl/volcl_shared.h"
#include "render/Bounds.hpp"
#include "render/Scene.hpp"

#include <vector>

namespace volcl {

/// The fog a scene asks for, resolved. With h = dot(p, up): extinction density where h <= base(p),
/// density * exp(-(h - base(p)) / falloff) above (none above when falloff is 0), zero outside the box;
/// base(p) is the scene's base, or the height map's nearest texel under p. Emission is color * extinction.
/// Example:
/// ```
/// volcl::FogField fog(scene.effects.fog, gridBounds(volume));   // reads the height map, if any
/// double sigma = fog.extinction({10, 2, 30});
/// ```
class FogField {
public:
    /// Throws IoError naming the height map when it cannot be read, DataError when it holds NaN/Inf.
    FogField(const FogEffect& fog, const WorldBox& volumeBox);

    const WorldBox& box() const noexcept { return box_; }
    const Vec3& up() const noexcept { return up_; }
    const FogEffect& effect() const noexcept { return fog_; }
    bool hasMap() const noexcept { return !map_.empty(); }
    /// The base (fog top of the constant layer) at world point p.
    double baseAt(const Vec3& p) const;
    double extinction(const Vec3& p) const;
    /// Ray parameters [t0, t1] of o + t d inside the box (false when it misses).
    bool clip(const Vec3& o, const Vec3& d, double& t0, double& t1) const;

    /// Kernel parameters; mapTexels() is the FOG_MAP buffer (row-major, image x fastest).
    VolclFogParams params() const;
    const std::vector<float>& mapTexels() const noexcept { return map_; }

private:
    FogEffect fog_;
    WorldBox box_;
    Vec3 up_{0, 1, 0};
    std::vector<float> map_; ///< base per texel, world units
    int mapW_ = 0, mapH_ = 0, axis0_ = 0, axis1_ = 2;
};

} // namespace volcl
