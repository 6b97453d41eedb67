/* Structs shared by host C++ and OpenCL C: one definition, same layout on both sides. */
#ifndef VOLCL_SHARED_H
#define VOLCL_SHARED_H

#ifdef __OPENCL_VERSION__
typedef uint volcl_uint;
typedef int volcl_int;
#else
#include <cstdint>
typedef std::uint32_t volcl_uint;
typedef std::int32_t volcl_int;
#endif

/* One interval of a merged transfer function, starting at knot s. Channels are (r, g, b, tau).
   Inside (s, next.s] the value is value + (x - s) * slope. Below the first knot the first knot's value
   holds; above the last, the last knot's value (slope 0). */
typedef struct VolclTfKnot {
    float value[4];
    float slope[4];
    float s;
    float pad[3];
} VolclTfKnot;

/* Grid geometry of a volume as kernels see it: node-centred, x fastest. */
typedef struct VolclGrid {
    volcl_uint nx, ny, nz, pad0;
    float origin[4];
    float spacing[4];
} VolclGrid;

/* One ellipsoid of the 3D Shepp-Logan phantom: p' = rot * p; inside when
   sum(((p' - centre) * invSemiAxis)^2) <= 1; adds `value` to the density. */
typedef struct VolclEllipsoid {
    float rot[9];
    float centre[3];
    float invSemiAxis[3];
    float value;
} VolclEllipsoid;

#ifndef __OPENCL_VERSION__
static_assert(sizeof(VolclEllipsoid) == 64, "VolclEllipsoid layout must match OpenCL C");
static_assert(sizeof(VolclTfKnot) == 48, "VolclTfKnot layout must match OpenCL C");
static_assert(sizeof(VolclGrid) == 48, "VolclGrid layout must match OpenCL C");
#endif

#endif
