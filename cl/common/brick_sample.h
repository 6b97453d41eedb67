/* Sampling from the brick pool for the brick ray marcher (cl/render/raymarch_bricks.cl): the grid sampler's rays
   and box (common/grid_sample.h), with every voxel read going through the page table of decoded bricks.

   The pool buffer (float) holds, in order: a header of 16 words (brick size x, y, z, brick grid x, y, z, and
   the distance from a brick's samples to its gradient-cache words (common/brick_gradient_cache.h; 0: the pool
   has none), as uint bits), the page table (4 words per brick: float offset of its samples in the pool, its level, a
   stand-in value, unused) and the brick samples. A brick at level l holds ceil(n / 2^l) samples per axis
   (x fastest); level VOLCL_BRICK_ABSENT means not decoded: the brick is in no ray's working set, or the
   transfer function hides everything around it, and its stand-in value (its minimum) is returned.

   The field is the trilinear interpolation, on the full-resolution lattice, of node values; a node's value
   is its own brick's level-l approximation there (the trilinear interpolation of that brick's samples at
   (node - origin) / 2^l, clamped to its last sample). One global lattice of node values means no cracks
   between bricks of different levels, whatever the levels. Where all 8 corners of a cell lie in one
   brick, the cell's interpolation equals a direct trilinear lookup in that brick (a trilinear function
   sampled at a finer lattice and interpolated again is itself), so only cells across a brick face pay for
   8 node lookups. At level 0 everywhere this is the grid sampler's arithmetic, value for value. */
#ifndef VOLCL_BRICK_SAMPLE_H
#define VOLCL_BRICK_SAMPLE_H

/* The grid sampler's helpers under other names; this file provides the sampling functions themselves. */
#define sample_volume volcl_grid_sample_volume_unused
#define sample_volume8 volcl_grid_sample_volume8_unused
#define sample_packet volcl_grid_sample_packet_unused
#define gradient volcl_grid_gradient_unused
#include "grid_sample.h"
#undef sample_volume
#undef sample_volume8
#undef sample_packet
#undef gradient

#define VOLCL_BRICK_ABSENT 0xffffffffu
#define VOLCL_BRICK_HEADER 16u

inline uint brick_index(__global const float* pool, uint3 b) {
    const uint gx = as_uint(pool[3]), gy = as_uint(pool[4]);
    return (b.z * gy + b.y) * gx + b.x;
}

/* Samples per axis of a brick at `level`, from its origin and the grid's dims. */
inline uint3 brick_samples(const VolclGridParams* G, uint3 bsize, uint3 o, uint level) {
    const uint3 n = min(bsize, (uint3)(G->dims[0], G->dims[1], G->dims[2]) - o);
    const uint s = (1u << level) - 1u;
    return (n + s) >> level;
}

/* The cell of one brick holding brick sample coordinates u (clamped to its m samples per axis, as the grid
   sampler clamps): its low and high corners, and u's fractions in it. */
inline float3 brick_cell(uint3 m, float3 u, uint3* lo, uint3* hi) {
    const int3 hiI = convert_int3(m) - 1;
    u = clamp(u, (float3)(0.0f), convert_float3(hiI));
    const int3 i0 = min(convert_int3(floor(u)), max(hiI - 1, (int3)(0)));
    *lo = convert_uint3(i0);
    *hi = convert_uint3(min(i0 + 1, hiI));
    return u - convert_float3(i0);
}

/* Offsets of the 8 corners (x fastest: v000 v100 v010 v110 v001 v101 v011 v111) of the cell from local node l0
   to l1 in a brick of m samples per axis. */
inline uint8 brick_corner_offsets(uint3 m, uint3 l0, uint3 l1) {
    const uint z0 = l0.z * m.x * m.y, z1 = l1.z * m.x * m.y, y0 = l0.y * m.x, y1 = l1.y * m.x;
    return (uint8)(z0 + y0 + l0.x, z0 + y0 + l1.x, z0 + y1 + l0.x, z0 + y1 + l1.x, z1 + y0 + l0.x,
                   z1 + y0 + l1.x, z1 + y1 + l0.x, z1 + y1 + l1.x);
}

/* The 8 corners, in that order, of the cell from local node l0 to l1 of one brick whose samples start at v. */
inline float8 brick_corners_level0(__global const float* v, uint3 m, uint3 l0, uint3 l1) {
    const uint8 o = brick_corner_offsets(m, l0, l1);
    return (float8)(v[o.s0], v[o.s1], v[o.s2], v[o.s3], v[o.s4], v[o.s5], v[o.s6], v[o.s7]);
}

/* Trilinear lookup in one decoded brick at level > 0: u in the brick's sample coordinates. */
inline float brick_coarse(__global const float* pool, uint off, uint3 m, float3 u) {
    uint3 lo, hi;
    const float3 f = brick_cell(m, u, &lo, &hi);
    const float8 c = brick_corners_level0(pool + off, m, lo, hi);
    const float c00 = c.s0 + f.x * (c.s1 - c.s0), c10 = c.s2 + f.x * (c.s3 - c.s2);
    const float c01 = c.s4 + f.x * (c.s5 - c.s4), c11 = c.s6 + f.x * (c.s7 - c.s6);
    const float c0 = c00 + f.y * (c10 - c00), c1 = c01 + f.y * (c11 - c01);
    return c0 + f.z * (c1 - c0);
}

/* The value of full-resolution node n (inside the grid). */
inline float brick_node(__global const float* pool, const VolclGridParams* G, uint3 n) {
    const uint3 bsize = (uint3)(as_uint(pool[0]), as_uint(pool[1]), as_uint(pool[2]));
    const uint3 b = n / bsize;
    __global const float* e = pool + VOLCL_BRICK_HEADER + 4u * brick_index(pool, b);
    const uint level = as_uint(e[1]);
    if (level == VOLCL_BRICK_ABSENT) return e[2];
    const uint off = as_uint(e[0]);
    const uint3 o = b * bsize;
    const uint3 m = brick_samples(G, bsize, o, level);
    const uint3 l = n - o;
    if (level == 0u) return pool[off + (l.z * m.y + l.y) * m.x + l.x];
    return brick_coarse(pool, off, m, convert_float3(l) * (1.0f / (float)(1u << level)));
}

/* The field at voxel coordinates p (clamped to the grid), as described above. */
inline float sample_volume(__global const float* pool, const VolclGridParams* G, float3 p) {
    const int3 hiI = (int3)((int)G->dims[0] - 1, (int)G->dims[1] - 1, (int)G->dims[2] - 1);
    p = clamp(p, (float3)(0.0f), convert_float3(hiI));
    int3 i0 = convert_int3(floor(p));
    i0 = min(i0, max(hiI - 1, (int3)(0)));
    const int3 i1 = min(i0 + 1, hiI);
    const float3 f = p - convert_float3(i0);
    const uint3 bsize = (uint3)(as_uint(pool[0]), as_uint(pool[1]), as_uint(pool[2]));
    const uint3 u0 = convert_uint3(i0), u1 = convert_uint3(i1);
    const uint3 b = u0 / bsize;
    float a00, e00, a10, e10, a01, e01, a11, e11;
    if (all(u1 / bsize == b)) {
        __global const float* e = pool + VOLCL_BRICK_HEADER + 4u * brick_index(pool, b);
        const uint level = as_uint(e[1]);
        if (level == VOLCL_BRICK_ABSENT) return e[2];
        const uint off = as_uint(e[0]);
        const uint3 o = b * bsize;
        const uint3 m = brick_samples(G, bsize, o, level);
        if (level != 0u)
            return brick_coarse(pool, off, m, (p - convert_float3(o)) * (1.0f / (float)(1u << level)));
        const float8 c = brick_corners_level0(pool + off, m, u0 - o, u1 - o);
        a00 = c.s0;
        e00 = c.s1;
        a10 = c.s2;
        e10 = c.s3;
        a01 = c.s4;
        e01 = c.s5;
        a11 = c.s6;
        e11 = c.s7;
    } else {
        a00 = brick_node(pool, G, (uint3)(u0.x, u0.y, u0.z));
        e00 = brick_node(pool, G, (uint3)(u1.x, u0.y, u0.z));
        a10 = brick_node(pool, G, (uint3)(u0.x, u1.y, u0.z));
        e10 = brick_node(pool, G, (uint3)(u1.x, u1.y, u0.z));
        a01 = brick_node(pool, G, (uint3)(u0.x, u0.y, u1.z));
        e01 = brick_node(pool, G, (uint3)(u1.x, u0.y, u1.z));
        a11 = brick_node(pool, G, (uint3)(u0.x, u1.y, u1.z));
        e11 = brick_node(pool, G, (uint3)(u1.x, u1.y, u1.z));
    }
    const float c00 = a00 + f.x * (e00 - a00), c10 = a10 + f.x * (e10 - a10);
    const float c01 = a01 + f.x * (e01 - a01), c11 = a11 + f.x * (e11 - a11);
    const float c0 = c00 + f.y * (c10 - c00), c1 = c01 + f.y * (c11 - c01);
    return c0 + f.z * (c1 - c0);
}

/* The node values at the 8 corners of the cell from node c0 to c1 (c1 = c0 + 1 inside the grid, c0 on a
   one-node axis), in the order above: the values sample_volume interpolates in that cell. The iso-surface
   cell walk (render/raymarch_iso.h) solves its cubic on them, so its roots lie on this field (it must not
   index the pool as a grid). */
inline float8 cell_corners(__global const float* pool, const VolclGridParams* G, int3 c0, int3 c1) {
    const uint3 u0 = convert_uint3(c0), u1 = convert_uint3(c1);
    const uint3 bsize = (uint3)(as_uint(pool[0]), as_uint(pool[1]), as_uint(pool[2]));
    const uint3 b = u0 / bsize;
    if (all(u1 / bsize == b)) {
        __global const float* e = pool + VOLCL_BRICK_HEADER + 4u * brick_index(pool, b);
        const uint level = as_uint(e[1]);
        if (level == VOLCL_BRICK_ABSENT) return (float8)(e[2]);
        if (level == 0u) {
            const uint3 o = b * bsize;
            return brick_corners_level0(pool + as_uint(e[0]), brick_samples(G, bsize, o, 0u), u0 - o, u1 - o);
        }
    }
    return (float8)(brick_node(pool, G, (uint3)(u0.x, u0.y, u0.z)),
                    brick_node(pool, G, (uint3)(u1.x, u0.y, u0.z)),
                    brick_node(pool, G, (uint3)(u0.x, u1.y, u0.z)),
                    brick_node(pool, G, (uint3)(u1.x, u1.y, u0.z)),
                    brick_node(pool, G, (uint3)(u0.x, u0.y, u1.z)),
                    brick_node(pool, G, (uint3)(u1.x, u0.y, u1.z)),
                    brick_node(pool, G, (uint3)(u0.x, u1.y, u1.z)),
                    brick_node(pool, G, (uint3)(u1.x, u1.y, u1.z)));
}

/* World-space gradient at voxel coordinates p (central differences, or Sobel-weighted). */
inline float3 gradient(__global const float* vol, const VolclGridParams* G, float3 p) {
    const float3 inv = v3(G->invSpacing);
#if defined(GRADIENT_SOBEL)
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

/* Eight points, lane by lane. */
PACKET_INLINE float8 sample_volume8(__global const float* vol, const VolclGridParams* G, float8 px, float8 py,
                                    float8 pz) {
    LaneF x, y, z, out;
    x.v = px;
    y.v = py;
    z.v = pz;
    for (int l = 0; l < RAY_LANES; ++l)
        out.a[l] = sample_volume(vol, G, (float3)(x.a[l], y.a[l], z.a[l]));
    return out.v;
}

PACKET_INLINE float8 sample_packet(__global const float* vol, const VolclGridParams* G, const RayPacket* r,
                                   float8 t) {
    return sample_volume8(vol, G, r->ox + t * r->dx, r->oy + t * r->dy, r->oz + t * r->dz);
}

#endif
