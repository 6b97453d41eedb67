/* Ray-marcher parameters shared by host C++ and OpenCL C (one definition, same layout on both sides). */
#ifndef VOLCL_RAYMARCH_SHARED_H
#define VOLCL_RAYMARCH_SHARED_H

#include "volcl_shared.h"

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
static_assert(sizeof(VolclRenderParams) == 16 * 9 + 16 * 6 + 64 * 5,
              "VolclRenderParams layout must match OpenCL C");
#endif

#endif
