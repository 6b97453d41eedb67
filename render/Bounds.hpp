// What every renderer's data has: a world-space box and a value range (the renderer interface reports both).
#pragma once

#include "render/VecMath.hpp"

namespace volcl {

/// Axis-aligned world box: the corner nearest -infinity and the extent per axis (>= 0). Kept as origin and
/// extent, not two corners, because framing and planning use the extent (a grid's is (n - 1) * spacing
/// exactly; hi - lo would round).
struct WorldBox {
    Vec3 origin{0, 0, 0};
    Vec3 extent{0, 0, 0};
    /// The far corner origin + extent.
    Vec3 hi() const noexcept { return {origin[0] + extent[0], origin[1] + extent[1], origin[2] + extent[2]}; }
};

/// Smallest and largest finite data value (both 0 when there is none).
struct ValueRange {
    double min = 0.0, max = 0.0;
};

} // namespace volcl
