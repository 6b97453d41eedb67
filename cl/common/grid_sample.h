/* Grid sampling for the grid ray marcher: voxel types, rays in voxel coordinates, the grid's box,
   trilinear or cubic B-spline samples (one ray or a packet) and gradients. */
#ifndef VOLCL_GRID_SAMPLE_H
#define VOLCL_GRID_SAMPLE_H

#include "camera_rays.h"

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
    float3 o;      /* origin in voxel coordinates */
    float3 d;      /* direction in voxel coordinates per world unit */
    float3 dWorld; /* unit direction in world */
    float3 oWorld;
} Ray;

/* A world ray in the grid's voxel coordinates; the ray parameter stays the world distance. */
inline Ray grid_ray(const VolclGridParams* G, WorldRay w) {
    Ray r;
    r.oWorld = w.o;
    r.dWorld = w.d;
    const float3 inv = v3(G->invSpacing);
    r.o = (r.oWorld - v3(G->origin)) * inv;
    r.d = r.dWorld * inv;
    return r;
}

inline float3 ray_at(const Ray* r, float t) {
    return r->o + t * r->d;
}

/* Upper corner of the grid's box in voxel coordinates: (nx - 1, ny - 1, nz - 1). */
inline float3 grid_hi(const VolclGridParams* G) {
    return (float3)(G->dims[0] - 1, G->dims[1] - 1, G->dims[2] - 1);
}

#ifdef FILTER_BSPLINE
/* Cubic B-spline reconstruction (render/grid/BsplineField.hpp): vol holds float coefficients with a
   margin of one below and two above each axis, so the 4x4x4 neighbourhood of any point in the box is in
   bounds without clamps. Sigg and Hadwiger's eight trilinear fetches pay off with hardware filtering; with
   buffers the 64 reads are the same, so the separable sum is taken directly, value and gradient together. */
inline void bspline_weights(float f, float4* w, float4* dw) {
    const float g = 1.0f - f, f2 = f * f;
    *w = (float4)(g * g * g, 3.0f * f2 * f - 6.0f * f2 + 4.0f, -3.0f * f2 * f + 3.0f * f2 + 3.0f * f + 1.0f,
                  f2 * f) *
         (1.0f / 6.0f);
    *dw = (float4)(-0.5f * g * g, 1.5f * f2 - 2.0f * f, -1.5f * f2 + f + 0.5f, 0.5f * f2);
}

/* The spline at voxel coordinates p (clamped to the grid) and, when grad is not NULL, its derivative per
   voxel unit. */
inline float bspline_eval(__global const float* coef, const VolclGridParams* G, float3 p, float3* grad) {
    const int3 hiI = (int3)((int)G->dims[0] - 1, (int)G->dims[1] - 1, (int)G->dims[2] - 1);
    p = clamp(p, (float3)(0.0f), convert_float3(hiI));
    const int3 i0 = min(convert_int3(floor(p)), max(hiI - 1, (int3)(0)));
    const float3 f = p - convert_float3(i0);
    float4 wx, wy, wz, dx, dy, dz;
    bspline_weights(f.x, &wx, &dx);
    bspline_weights(f.y, &wy, &dy);
    bspline_weights(f.z, &wz, &dz);
    const uint px = G->dims[0] + 3u, pxy = px * (G->dims[1] + 3u);
    __global const float* base = coef + (size_t)i0.z * pxy + (size_t)i0.y * px + (size_t)i0.x;
    const float wya[4] = {wy.x, wy.y, wy.z, wy.w}, dya[4] = {dy.x, dy.y, dy.z, dy.w};
    const float wza[4] = {wz.x, wz.y, wz.z, wz.w}, dza[4] = {dz.x, dz.y, dz.z, dz.w};
    float v = 0.0f, gx = 0.0f, gy = 0.0f, gz = 0.0f;
    for (int c = 0; c < 4; ++c) {
        float rv = 0.0f, rx = 0.0f, ry = 0.0f; /* this z slice summed over y */
        for (int b = 0; b < 4; ++b) {
            const float4 row = vload4(0, base + (size_t)c * pxy + (size_t)b * px);
            const float sw = dot(wx, row), sd = dot(dx, row);
            rv += wya[b] * sw;
            rx += wya[b] * sd;
            ry += dya[b] * sw;
        }
        v += wza[c] * rv;
        gx += wza[c] * rx;
        gy += wza[c] * ry;
        gz += dza[c] * rv;
    }
    if (grad) *grad = select((float3)(gx, gy, gz), (float3)(0.0f), hiI == (int3)(0));
    return v;
}

inline float sample_volume(__global const voxel_t* vol, const VolclGridParams* G, float3 p) {
    return bspline_eval(vol, G, p, 0);
}
#else
/* Trilinear interpolation at voxel coordinates p (clamped to the grid). */
inline float sample_volume(__global const voxel_t* vol, const VolclGridParams* G, float3 p) {
    const int3 hiI = (int3)((int)G->dims[0] - 1, (int)G->dims[1] - 1, (int)G->dims[2] - 1);
    const float3 hi = convert_float3(hiI);
    p = clamp(p, (float3)(0.0f), hi);
    int3 i0 = convert_int3(floor(p));
    i0 = min(i0, max(hiI - 1, (int3)(0)));
    const int3 i1 = min(i0 + 1, hiI);
    const float3 f = p - convert_float3(i0);
    const uint nx = G->dims[0], nxy = G->dims[0] * G->dims[1];
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

#endif

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

/* World-space gradient at voxel coordinates p. */
inline float3 gradient(__global const voxel_t* vol, const VolclGridParams* G, float3 p) {
    const float3 inv = v3(G->invSpacing);
#if defined(FILTER_BSPLINE)
    float3 g;
    bspline_eval(vol, G, p, &g);
    return g * inv;
#elif defined(GRADIENT_SOBEL)
    /* Sobel-weighted central differences: each axis smoothed over the other two with weights 1-2-1. */
    float3 g = (float3)(0.0f);
    for (int a = -1; a <= 1; ++a)
        for (int b = -1; b <= 1; ++b) {
            const float w = (a == 0 ? 2.0f : 1.0f) * (b == 0 ? 2.0f : 1.0f);
            g.x += w * (sample_volume(vol, G, p + (float3)(1, a, b)) -
                        sample_volume(vol, G, p + (float3)(-1, a, b)));
            g.y += w * (sample_volume(vol, G, p + (float3)(a, 1, b)) -
                        sample_volume(vol, G, p + (float3)(a, -1, b)));
            g.z += w * (sample_volume(vol, G, p + (float3)(a, b, 1)) -
                        sample_volume(vol, G, p + (float3)(a, b, -1)));
        }
    return g * (1.0f / 32.0f) * inv;
#else
    const float gx =
        sample_volume(vol, G, p + (float3)(1, 0, 0)) - sample_volume(vol, G, p - (float3)(1, 0, 0));
    const float gy =
        sample_volume(vol, G, p + (float3)(0, 1, 0)) - sample_volume(vol, G, p - (float3)(0, 1, 0));
    const float gz =
        sample_volume(vol, G, p + (float3)(0, 0, 1)) - sample_volume(vol, G, p - (float3)(0, 0, 1));
    return (float3)(gx, gy, gz) * 0.5f * inv;
#endif
}

#ifdef FILTER_BSPLINE
/* The spline at eight points, lane by lane. */
PACKET_INLINE float8 sample_volume8(__global const voxel_t* vol, const VolclGridParams* G, float8 px,
                                    float8 py, float8 pz) {
    LaneF x, y, z, out;
    x.v = px;
    y.v = py;
    z.v = pz;
    for (int l = 0; l < RAY_LANES; ++l)
        out.a[l] = bspline_eval(vol, G, (float3)(x.a[l], y.a[l], z.a[l]), 0);
    return out.v;
}
#else
/* sample_volume for eight points at once: the same clamps, cell choice and lerp order per lane. */
PACKET_INLINE float8 sample_volume8(__global const voxel_t* vol, const VolclGridParams* G, float8 px,
                                    float8 py, float8 pz) {
    const int hx = (int)G->dims[0] - 1, hy = (int)G->dims[1] - 1, hz = (int)G->dims[2] - 1;
    px = clamp(px, 0.0f, (float)hx);
    py = clamp(py, 0.0f, (float)hy);
    pz = clamp(pz, 0.0f, (float)hz);
    /* Integer min/max/clamp of a vector get vector bounds throughout the packet code: Oclgrind 21.10 computes
       the (vector, scalar) overloads wrongly in every lane but the first (tests/oclgrind/int_clamp_scalar.cl). */
    const int8 ix = min(convert_int8(floor(px)), (int8)(max(hx - 1, 0)));
    const int8 iy = min(convert_int8(floor(py)), (int8)(max(hy - 1, 0)));
    const int8 iz = min(convert_int8(floor(pz)), (int8)(max(hz - 1, 0)));
    const float8 fx = px - convert_float8(ix), fy = py - convert_float8(iy), fz = pz - convert_float8(iz);
    const uint nx = G->dims[0];
    const uint8 xi = convert_uint8(ix);
    LaneF a00, a10, a01, a11, e00, e10, e01, e11; /* a: value at i0.x, e: at i0.x + 1 */
#ifdef CORNER_VOXELS
    /* uint8 volumes can come as 8 bytes per cell: its corners (x, y, z), (x+1, y, z), (x, y+1, z),
       (x+1, y+1, z), then the same at z+1, neighbours clamped to the grid like i1 below. One aligned 8-byte
       load per sample instead of four 2-byte loads from four cache lines. Cells are stored in 4x4x4 bricks
       (512 bytes), so a ray moving in y or z stays in the cache lines it has already loaded. */
    const uint nbx = (nx + 3u) >> 2, nby = (G->dims[1] + 3u) >> 2;
    const uint8 uy = convert_uint8(iy), uz = convert_uint8(iz);
    LaneU b;
    b.v = ((((uz >> 2) * nby + (uy >> 2)) * nbx + (xi >> 2)) << 6) | ((uz & 3u) << 4) | ((uy & 3u) << 2) |
          (xi & 3u);
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const float8 c = convert_float8(vload8(0, (__global const uchar*)vol + (size_t)b.a[l] * 8));
        a00.a[l] = c.s0;
        e00.a[l] = c.s1;
        a10.a[l] = c.s2;
        e10.a[l] = c.s3;
        a01.a[l] = c.s4;
        e01.a[l] = c.s5;
        a11.a[l] = c.s6;
        e11.a[l] = c.s7;
    }
#else
    const uint nxy = nx * G->dims[1];
    const uint8 z0 = convert_uint8(iz) * nxy, y0 = convert_uint8(iy) * nx;
    const uint8 z1 = convert_uint8(min(iz + 1, (int8)(hz))) * nxy,
                y1 = convert_uint8(min(iy + 1, (int8)(hy))) * nx;
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
        a00.a[l] = v00.x;
        e00.a[l] = v00.y;
        a10.a[l] = v10.x;
        e10.a[l] = v10.y;
        a01.a[l] = v01.x;
        e01.a[l] = v01.y;
        a11.a[l] = v11.x;
        e11.a[l] = v11.y;
    }
#endif
    const float8 c00 = a00.v + fx * (e00.v - a00.v), c10 = a10.v + fx * (e10.v - a10.v);
    const float8 c01 = a01.v + fx * (e01.v - a01.v), c11 = a11.v + fx * (e11.v - a11.v);
    const float8 c0 = c00 + fy * (c10 - c00), c1 = c01 + fy * (c11 - c01);
    return c0 + fz * (c1 - c0);
}

#endif

PACKET_INLINE float8 sample_packet(__global const voxel_t* vol, const VolclGridParams* G, const RayPacket* r,
                                   float8 t) {
    return sample_volume8(vol, G, r->ox + t * r->dx, r->oy + t * r->dy, r->oz + t * r->dz);
}

#endif
