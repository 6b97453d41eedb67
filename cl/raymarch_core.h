/* Ray-marcher core shared by every ray-marching kernel: camera rays, box clipping, trilinear sampling. */
#ifndef VOLCL_RAYMARCH_CORE_H
#define VOLCL_RAYMARCH_CORE_H

#include "raymarch_shared.h"

/* Voxels stay in their stored type on the device (a quarter of the memory traffic for uint8 data). */
#if VOXEL_TYPE == 1
typedef uchar voxel_t;
#elif VOXEL_TYPE == 2
typedef ushort voxel_t;
#elif VOXEL_TYPE == 3
typedef short voxel_t;
#else
typedef float voxel_t; /* VOXEL_TYPE 0 or undefined */
#endif

typedef struct {
    float3 o;       /* origin in voxel coordinates */
    float3 d;       /* direction in voxel coordinates per world unit */
    float3 dWorld;  /* unit direction in world */
    float3 oWorld;
} Ray;

inline float3 v3(const float a[4]) { return (float3)(a[0], a[1], a[2]); }

/* Trilinear interpolation at voxel coordinates p (clamped to the grid). */
inline float sample_volume(__global const voxel_t* vol, const VolclRenderParams* P, float3 p) {
    const int3 hiI = (int3)((int)P->dims[0] - 1, (int)P->dims[1] - 1, (int)P->dims[2] - 1);
    const float3 hi = convert_float3(hiI);
    p = clamp(p, (float3)(0.0f), hi);
    int3 i0 = convert_int3(floor(p));
    i0 = min(i0, max(hiI - 1, (int3)(0)));
    const int3 i1 = min(i0 + 1, hiI);
    const float3 f = p - convert_float3(i0);
    const uint nx = P->dims[0], nxy = P->dims[0] * P->dims[1];
    const uint z0 = (uint)i0.z * nxy, z1 = (uint)i1.z * nxy, y0 = (uint)i0.y * nx, y1 = (uint)i1.y * nx;
    /* x neighbours are adjacent: one two-wide load each. The buffer carries one spare voxel, so the pair is
       in bounds even for a one-voxel-wide grid, where the second value has weight f.x = 0. */
    const float2 a00 = convert_float2(vload2(0, vol + z0 + y0 + i0.x));
    const float2 a10 = convert_float2(vload2(0, vol + z0 + y1 + i0.x));
    const float2 a01 = convert_float2(vload2(0, vol + z1 + y0 + i0.x));
    const float2 a11 = convert_float2(vload2(0, vol + z1 + y1 + i0.x));
    const float c00 = a00.x + f.x * (a00.y - a00.x), c10 = a10.x + f.x * (a10.y - a10.x);
    const float c01 = a01.x + f.x * (a01.y - a01.x), c11 = a11.x + f.x * (a11.y - a11.x);
    const float c0 = c00 + f.y * (c10 - c00), c1 = c01 + f.y * (c11 - c01);
    return c0 + f.z * (c1 - c0);
}

/* Ray interval inside the box [0, n-1] (voxel coordinates), intersected with [tmin, tmax]. */
inline float2 clip_box(float3 o, float3 d, float3 hi, float tmin, float tmax) {
    const float oa[3] = {o.x, o.y, o.z}, da[3] = {d.x, d.y, d.z}, ha[3] = {hi.x, hi.y, hi.z};
    for (int a = 0; a < 3; ++a) {
        if (da[a] == 0.0f) {
            if (oa[a] < 0.0f || oa[a] > ha[a]) return (float2)(1.0f, 0.0f);
        } else {
            const float inv = 1.0f / da[a];
            float t1 = (0.0f - oa[a]) * inv, t2 = (ha[a] - oa[a]) * inv;
            tmin = fmax(tmin, fmin(t1, t2));
            tmax = fmin(tmax, fmax(t1, t2));
        }
    }
    return (float2)(tmin, tmax);
}

inline Ray camera_ray(const VolclRenderParams* P, uint x, uint y) {
    const float ndcX = 2.0f * ((float)x + 0.5f) / (float)P->width - 1.0f;
    const float ndcY = 1.0f - 2.0f * ((float)y + 0.5f) / (float)P->height;
    Ray r;
    const float3 f = v3(P->camForward), right = v3(P->camRight), up = v3(P->camUp);
    if (P->dims[3]) {
        r.oWorld = v3(P->camOrigin);
        r.dWorld = normalize(f + ndcX * right + ndcY * up);
    } else {
        r.oWorld = v3(P->camOrigin) + ndcX * right + ndcY * up;
        r.dWorld = f;
    }
    const float3 inv = v3(P->volInvSpacing);
    r.o = (r.oWorld - v3(P->volOrigin)) * inv;
    r.d = r.dWorld * inv;
    return r;
}

inline float3 ray_at(const Ray* r, float t) { return r->o + t * r->d; }

#endif
