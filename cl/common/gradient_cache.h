/* The gradient cache (render.gradient "cache" / "cache-nearest"): one uint per voxel holding the voxel's
   central-difference world gradient as a 2x12-bit octahedral direction (bits 0-23) and an 8-bit minifloat of
   its L1 norm relative to VolclGridParams::gradientMax (bits 24-31; 0: zero gradient). Built once per volume
   by gradient_cache.cl; the packet ray marcher reads it instead of six trilinear samples per gradient.
   Integer volumes whose values span at most 511 use the exact form instead (GRADIENT_CACHE 3): the three
   voxel differences of the central difference, each an integer in [-511, 511], as 10 bits plus 512 (bits
   0-9 x, 10-19 y, 20-29 z), so the cache loses nothing and its blend decodes with one conversion per axis. */
#ifndef VOLCL_GRADIENT_CACHE_H
#define VOLCL_GRADIENT_CACHE_H

#include "grid_sample.h"

#pragma OPENCL FP_CONTRACT OFF

/* Octahedral coordinates in [-1, 1] take 4096 levels; the L1 norm's minifloat keeps 4 exponent bits (ratios
   2^-15 .. 1 of gradientMax) and 4 mantissa bits (rounded: relative error at most 2^-5). */
#define GCACHE_OCT_LEVELS 4095.0f
#define GCACHE_EXP_BIAS 112u

/* Packs world gradient g (ratio of its L1 norm to gMax in (0, 1]). Non-finite or tiny gradients pack as 0. */
inline uint gcache_pack(float3 g, float gMax) {
    const float l1 = fabs(g.x) + fabs(g.y) + fabs(g.z);
    if (!(l1 > 0.0f) || !isfinite(l1)) return 0u;
    const float ratio = fmin(l1 / gMax, 1.0f);
    const uint bits = as_uint(ratio) + (1u << 18); /* round the mantissa to 4 bits */
    const int code = (int)(bits >> 19) - (int)(GCACHE_EXP_BIAS << 4);
    if (code < 1) return 0u;
    float px = g.x / l1, py = g.y / l1;
    if (g.z < 0.0f) {
        const float fx = (1.0f - fabs(py)) * (px >= 0.0f ? 1.0f : -1.0f);
        const float fy = (1.0f - fabs(px)) * (py >= 0.0f ? 1.0f : -1.0f);
        px = fx;
        py = fy;
    }
    const uint u = (uint)rint((px * 0.5f + 0.5f) * GCACHE_OCT_LEVELS);
    const uint v = (uint)rint((py * 0.5f + 0.5f) * GCACHE_OCT_LEVELS);
    return min(u, 4095u) | (min(v, 4095u) << 12) | ((uint)min(code, 255) << 24);
}

/* The exact form of integer differences dx, dy, dz (each in [-511, 511]). */
inline uint gcache_pack_exact(int dx, int dy, int dz) {
    return (uint)(dx + 512) | ((uint)(dy + 512) << 10) | ((uint)(dz + 512) << 20);
}

/* Unpacks eight cache words into gradients in units of gMax (the L1 norm times the unit-L1 direction). */
PACKET_INLINE void gcache_unpack8(uint8 w, float8* gx, float8* gy, float8* gz) {
    const float8 u = convert_float8(w & 0xFFFu) * (2.0f / GCACHE_OCT_LEVELS) - 1.0f;
    const float8 v = convert_float8((w >> 12) & 0xFFFu) * (2.0f / GCACHE_OCT_LEVELS) - 1.0f;
    const uint8 code = w >> 24;
    const float8 m = select(as_float8((code + (GCACHE_EXP_BIAS << 4)) << 19), (float8)(0.0f), code == 0u);
    const float8 z = 1.0f - fabs(u) - fabs(v);
    const float8 t = fmax(-z, 0.0f);
    *gx = m * (u - copysign(t, u));
    *gy = m * (v - copysign(t, v));
    *gz = m * z;
}

/* One cache word decoded to its gradient in units of gMax (gcache_unpack8 for a single word). */
inline float3 gcache_unpack(uint w) {
    const float u = (float)(w & 0xFFFu) * (2.0f / GCACHE_OCT_LEVELS) - 1.0f;
    const float v = (float)((w >> 12) & 0xFFFu) * (2.0f / GCACHE_OCT_LEVELS) - 1.0f;
    const uint code = w >> 24;
    const float m = code == 0u ? 0.0f : as_float((code + (GCACHE_EXP_BIAS << 4)) << 19);
    const float z = 1.0f - fabs(u) - fabs(v);
    const float t = fmax(-z, 0.0f);
    return (float3)(m * (u - copysign(t, u)), m * (v - copysign(t, v)), m * z);
}

/* Lane l's eight corner words (x fastest) into the corner vectors w[0..7]. */
PACKET_INLINE void gcache_set_lane(LaneU* w, int l, uint8 words) {
    w[0].a[l] = words.s0;
    w[1].a[l] = words.s1;
    w[2].a[l] = words.s2;
    w[3].a[l] = words.s3;
    w[4].a[l] = words.s4;
    w[5].a[l] = words.s5;
    w[6].a[l] = words.s6;
    w[7].a[l] = words.s7;
}

/* The trilinear blend of eight corner words per lane (corner c: bit 0 x, bit 1 y, bit 2 z) at cell fractions
   (fx, fy, fz), in world units (times gMax). */
PACKET_INLINE void gcache_blend8(const LaneU* w, float8 fx, float8 fy, float8 fz, float gMax, float8* gx,
                                 float8* gy, float8* gz) {
    float8 cx[8], cy[8], cz[8];
    _Pragma("unroll") for (int c = 0; c < 8; ++c) gcache_unpack8(w[c].v, &cx[c], &cy[c], &cz[c]);
    const float8 wx0 = 1.0f - fx, wy0 = 1.0f - fy, wz0 = 1.0f - fz;
    const float8 k[8] = {wx0 * wy0 * wz0, fx * wy0 * wz0, wx0 * fy * wz0, fx * fy * wz0,
                         wx0 * wy0 * fz,  fx * wy0 * fz,  wx0 * fy * fz,  fx * fy * fz};
    float8 sx = (float8)(0.0f), sy = (float8)(0.0f), sz = (float8)(0.0f);
    _Pragma("unroll") for (int c = 0; c < 8; ++c) {
        sx += k[c] * cx[c];
        sy += k[c] * cy[c];
        sz += k[c] * cz[c];
    }
    *gx = sx * gMax;
    *gy = sy * gMax;
    *gz = sz * gMax;
}

/* The trilinear blend of eight exact-form corner words per lane (as gcache_blend8), in world units: the
   offset and the spacing applied once after the blend (the weights sum to one), so each corner costs one
   conversion and one mad per axis. */
PACKET_INLINE void gcache_blend_exact8(const LaneU* w, float8 fx, float8 fy, float8 fz,
                                       const float* invSpacing, float8* gx, float8* gy, float8* gz) {
    const float8 wx0 = 1.0f - fx, wy0 = 1.0f - fy, wz0 = 1.0f - fz;
    const float8 k[8] = {wx0 * wy0 * wz0, fx * wy0 * wz0, wx0 * fy * wz0, fx * fy * wz0,
                         wx0 * wy0 * fz,  fx * wy0 * fz,  wx0 * fy * fz,  fx * fy * fz};
    float8 sx = (float8)(0.0f), sy = (float8)(0.0f), sz = (float8)(0.0f);
    _Pragma("unroll") for (int c = 0; c < 8; ++c) {
        sx = mad(k[c], convert_float8(w[c].v & 1023u), sx);
        sy = mad(k[c], convert_float8((w[c].v >> 10) & 1023u), sy);
        sz = mad(k[c], convert_float8(w[c].v >> 20), sz);
    }
    *gx = (sx - 512.0f) * (0.5f * invSpacing[0]);
    *gy = (sy - 512.0f) * (0.5f * invSpacing[1]);
    *gz = (sz - 512.0f) * (0.5f * invSpacing[2]);
}

#if GRADIENT_CACHE == 2
/* World gradients of the packet at voxel points (px, py, pz): the nearest voxel's cache word (one fetch). */
PACKET_INLINE void gcache_gradient8(__global const uint* cache, const VolclGridParams* G, float8 px,
                                    float8 py, float8 pz, float8* gx, float8* gy, float8* gz) {
    const int hx = (int)G->dims[0] - 1, hy = (int)G->dims[1] - 1, hz = (int)G->dims[2] - 1;
    const int8 ix = clamp(convert_int8(rint(px)), (int8)(0), (int8)(hx));
    const int8 iy = clamp(convert_int8(rint(py)), (int8)(0), (int8)(hy));
    const int8 iz = clamp(convert_int8(rint(pz)), (int8)(0), (int8)(hz));
    LaneU idx, w;
    idx.v = (convert_uint8(iz) * G->dims[1] + convert_uint8(iy)) * G->dims[0] + convert_uint8(ix);
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) w.a[l] = cache[idx.a[l]];
    gcache_unpack8(w.v, gx, gy, gz);
    *gx *= G->gradientMax;
    *gy *= G->gradientMax;
    *gz *= G->gradientMax;
}
#else
/* World gradients of the packet at voxel points (px, py, pz): the trilinear blend of the eight voxels' cached
   gradients, which is the central difference of the trilinear field away from the border (the reference's
   gradient) up to the quantisation (none in the exact form, GRADIENT_CACHE 3). Cells and clamps as
   sample_volume8. */
PACKET_INLINE void gcache_gradient8(__global const uint* cache, const VolclGridParams* G, float8 px,
                                    float8 py, float8 pz, float8* gx, float8* gy, float8* gz) {
    const int hx = (int)G->dims[0] - 1, hy = (int)G->dims[1] - 1, hz = (int)G->dims[2] - 1;
    px = clamp(px, 0.0f, (float)hx);
    py = clamp(py, 0.0f, (float)hy);
    pz = clamp(pz, 0.0f, (float)hz);
    const int8 ix = min(convert_int8(floor(px)), (int8)(max(hx - 1, 0)));
    const int8 iy = min(convert_int8(floor(py)), (int8)(max(hy - 1, 0)));
    const int8 iz = min(convert_int8(floor(pz)), (int8)(max(hz - 1, 0)));
    const float8 fx = px - convert_float8(ix), fy = py - convert_float8(iy), fz = pz - convert_float8(iz);
    const uint nx = G->dims[0], nxy = nx * G->dims[1];
    const uint8 xi = convert_uint8(ix);
    const uint8 z0 = convert_uint8(iz) * nxy, y0 = convert_uint8(iy) * nx;
    const uint8 z1 = convert_uint8(min(iz + 1, (int8)(hz))) * nxy,
                y1 = convert_uint8(min(iy + 1, (int8)(hy))) * nx;
    LaneU b00, b10, b01, b11, w[8];
    b00.v = z0 + y0 + xi;
    b10.v = z0 + y1 + xi;
    b01.v = z1 + y0 + xi;
    b11.v = z1 + y1 + xi;
    /* x neighbours are adjacent: one two-word load each (the cache carries one spare word). */
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const uint2 c00 = vload2(0, cache + b00.a[l]), c10 = vload2(0, cache + b10.a[l]);
        const uint2 c01 = vload2(0, cache + b01.a[l]), c11 = vload2(0, cache + b11.a[l]);
        gcache_set_lane(w, l, (uint8)(c00, c10, c01, c11));
    }
#if GRADIENT_CACHE == 3
    gcache_blend_exact8(w, fx, fy, fz, G->invSpacing, gx, gy, gz);
#else
    gcache_blend8(w, fx, fy, fz, G->gradientMax, gx, gy, gz);
#endif
}
#endif

#endif
