/* Ray-marcher core shared by every ray-marching kernel: camera rays, box clipping, trilinear sampling. */
#ifndef VOLCL_RAYMARCH_CORE_H
#define VOLCL_RAYMARCH_CORE_H

#include "volcl_shared.h"

#pragma OPENCL FP_CONTRACT OFF

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

/* ---------------- ray packets ----------------
   PoCL runs one work-item's ray loop as scalar code (it cannot vectorise divergent loops across
   work-items), so the hot DVR kernels march RAY_LANES rays per work-item in explicit float8 vectors:
   a 4x2 pixel block whose rays stay close, so they sample the same cache lines and end together.
   Lanes finish independently (masks); the arithmetic per lane is the scalar kernel's, operation for
   operation, so the image is the same. */
#define RAY_LANES 8
/* Packet helpers are inlined into the ray loop: as calls they pass their float8 values through the stack. */
#define PACKET_INLINE __attribute__((always_inline)) inline
#define PACKET_W 4
#define PACKET_H 2

typedef union { float8 v; float a[8]; } LaneF;
typedef union { int8 v; int a[8]; } LaneI;
typedef union { uint8 v; uint a[8]; } LaneU;

/* A packet of rays in voxel coordinates: origin o, direction d (per world unit). */
typedef struct {
    float8 ox, oy, oz, dx, dy, dz;
} RayPacket;

/* sample_volume for eight points at once: the same clamps, cell choice and lerp order per lane. */
PACKET_INLINE float8 sample_volume8(__global const voxel_t* vol, const VolclRenderParams* P, float8 px,
                                    float8 py, float8 pz) {
    const int hx = (int)P->dims[0] - 1, hy = (int)P->dims[1] - 1, hz = (int)P->dims[2] - 1;
    px = clamp(px, 0.0f, (float)hx);
    py = clamp(py, 0.0f, (float)hy);
    pz = clamp(pz, 0.0f, (float)hz);
    const int8 ix = min(convert_int8(floor(px)), max(hx - 1, 0));
    const int8 iy = min(convert_int8(floor(py)), max(hy - 1, 0));
    const int8 iz = min(convert_int8(floor(pz)), max(hz - 1, 0));
    const float8 fx = px - convert_float8(ix), fy = py - convert_float8(iy), fz = pz - convert_float8(iz);
    const uint nx = P->dims[0];
    const uint8 xi = convert_uint8(ix);
    LaneF a00, a10, a01, a11, e00, e10, e01, e11; /* a: value at i0.x, e: at i0.x + 1 */
#ifdef CORNER_VOXELS
    /* uint8 volumes can come as 8 bytes per cell: its corners (x, y, z), (x+1, y, z), (x, y+1, z),
       (x+1, y+1, z), then the same at z+1, neighbours clamped to the grid like i1 below. One aligned 8-byte
       load per sample instead of four 2-byte loads from four cache lines. Cells are stored in 4x4x4 bricks
       (512 bytes), so a ray moving in y or z stays in the cache lines it has already loaded. */
    const uint nbx = (nx + 3u) >> 2, nby = (P->dims[1] + 3u) >> 2;
    const uint8 uy = convert_uint8(iy), uz = convert_uint8(iz);
    LaneU b;
    b.v = ((((uz >> 2) * nby + (uy >> 2)) * nbx + (xi >> 2)) << 6) | ((uz & 3u) << 4) | ((uy & 3u) << 2) | (xi & 3u);
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const float8 c = convert_float8(vload8(0, (__global const uchar*)vol + (size_t)b.a[l] * 8));
        a00.a[l] = c.s0; e00.a[l] = c.s1;
        a10.a[l] = c.s2; e10.a[l] = c.s3;
        a01.a[l] = c.s4; e01.a[l] = c.s5;
        a11.a[l] = c.s6; e11.a[l] = c.s7;
    }
#else
    const uint nxy = nx * P->dims[1];
    const uint8 z0 = convert_uint8(iz) * nxy, y0 = convert_uint8(iy) * nx;
    const uint8 z1 = convert_uint8(min(iz + 1, hz)) * nxy, y1 = convert_uint8(min(iy + 1, hy)) * nx;
    LaneU b00, b10, b01, b11;
    b00.v = z0 + y0 + xi;
    b10.v = z0 + y1 + xi;
    b01.v = z1 + y0 + xi;
    b11.v = z1 + y1 + xi;
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const float2 v00 = convert_float2(vload2(0, vol + b00.a[l]));
        const float2 v10 = convert_float2(vload2(0, vol + b10.a[l]));
        const float2 v01 = convert_float2(vload2(0, vol + b01.a[l]));
        const float2 v11 = convert_float2(vload2(0, vol + b11.a[l]));
        a00.a[l] = v00.x; e00.a[l] = v00.y;
        a10.a[l] = v10.x; e10.a[l] = v10.y;
        a01.a[l] = v01.x; e01.a[l] = v01.y;
        a11.a[l] = v11.x; e11.a[l] = v11.y;
    }
#endif
    const float8 c00 = a00.v + fx * (e00.v - a00.v), c10 = a10.v + fx * (e10.v - a10.v);
    const float8 c01 = a01.v + fx * (e01.v - a01.v), c11 = a11.v + fx * (e11.v - a11.v);
    const float8 c0 = c00 + fy * (c10 - c00), c1 = c01 + fy * (c11 - c01);
    return c0 + fz * (c1 - c0);
}

PACKET_INLINE float8 sample_packet(__global const voxel_t* vol, const VolclRenderParams* P, const RayPacket* r,
                                   float8 t) {
    return sample_volume8(vol, P, r->ox + t * r->dx, r->oy + t * r->dy, r->oz + t * r->dz);
}

#endif
