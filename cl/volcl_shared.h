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

/* Ray marcher (cl/raymarch*.cl). */
#define VOLCL_MAX_LIGHTS 4
#define VOLCL_MAX_CLIP_PLANES 4
#define VOLCL_MAX_ISOSURFACES 4

/* Light kinds (lightPos[i][3]). */
#define VOLCL_LIGHT_DIRECTIONAL 0
#define VOLCL_LIGHT_POINT 1
#define VOLCL_LIGHT_HEAD 2

/* Everything a frame needs besides buffers; values that change per frame live here, not in -D defines,
   so changing the camera or the TF never rebuilds a kernel. Vectors are xyz + one spare float. */
typedef struct VolclRenderParams {
    float camOrigin[4];  /* orthographic: eye; perspective: eye */
    float camRight[4];   /* r scaled by the half-width of the view (world units or tan(fov/2) * aspect) */
    float camUp[4];      /* u scaled by the half-height of the view */
    float camForward[4]; /* f */
    float volOrigin[4];  /* world position of voxel (0,0,0) */
    float volSpacing[4];
    float volInvSpacing[4];
    volcl_uint dims[4];      /* nx, ny, nz, perspective flag */
    volcl_uint macroDims[4]; /* macrocells per axis, voxels per macrocell edge */
    volcl_uint width, height, knotCount, tableSize;
    float step, earlyTermination, domainLo, domainHi;
    float tableMaxLength, shadowStep, gradientMin, pad0;
    volcl_uint tableLengths, lightCount, clipCount, isoCount;
    float ambient, diffuse, specular, shininess;
    float albedo, phaseG, pad1, pad2;
    float lightPos[VOLCL_MAX_LIGHTS][4];   /* xyz: direction toward the light or position; w: kind */
    float lightColor[VOLCL_MAX_LIGHTS][4]; /* rgb * intensity */
    float clipPlane[VOLCL_MAX_CLIP_PLANES][4]; /* keep points with dot(n, x) + w >= 0 */
    float isoValue[VOLCL_MAX_ISOSURFACES][4];  /* x: value */
    float isoColor[VOLCL_MAX_ISOSURFACES][4];  /* straight rgb, opacity */
} VolclRenderParams;

#ifndef __OPENCL_VERSION__
static_assert(sizeof(VolclEllipsoid) == 64, "VolclEllipsoid layout must match OpenCL C");
static_assert(sizeof(VolclTfKnot) == 48, "VolclTfKnot layout must match OpenCL C");
static_assert(sizeof(VolclGrid) == 48, "VolclGrid layout must match OpenCL C");
static_assert(sizeof(VolclRenderParams) == 16 * 9 + 16 * 6 + 64 * 5,
              "VolclRenderParams layout must match OpenCL C");
#endif

#endif
