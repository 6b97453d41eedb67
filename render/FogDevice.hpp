// The fog's kernel side for every renderer that composites it: parameters and the FOG_MAP buffer, with the
// height map read and uploaded again only when the map or what places it changes.
#pragma once

#include "cl/volcl_shared.h"
#include "core/runtime/ClRuntime.hpp"
#include "render/Bounds.hpp"
#include "render/Scene.hpp"

#include <string>

namespace volcl {

/// Owned by a renderer; update() on every rebuild (the viewer rebuilds when its step changes), buffer() as the
/// kernel argument.
class FogDevice {
public:
    /// The kernel parameters of `fog` resolved against `volumeBox`. With `withMap` the buffer holds the height
    /// map's texels; the image is read only when its file, value range, box or up differ from the last call.
    /// Throws what FogField throws (IoError naming the map, DataError on NaN/Inf texels).
    VolclFogParams update(ComputeContext& cc, const FogEffect& fog, const WorldBox& volumeBox, bool withMap);
    /// The FOG_MAP kernel argument: the map, or one unused float.
    const DeviceBuffer<float>& buffer(ComputeContext& cc);

private:
    DeviceBuffer<float> map_;
    std::string key_; ///< what the buffer holds: the map's path and everything that places it
    volcl_uint axes_[2] = {0, 2}, size_[2] = {1, 1};
};

} // namespace volcl
