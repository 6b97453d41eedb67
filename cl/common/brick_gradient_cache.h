/* The gradient cache of compressed bricks (render.gradient "cache" / "cache-nearest" on a .vcz): the grid's
   packed words (common/gradient_cache.h, same format and gradientMax) for the nodes of the global lattice of
   common/brick_sample.h, stored in the brick pool itself at a fixed distance (pool header word 6) after each
   brick's samples, one word per sample. Built by cl/render/brick_gradient_cache.cl when a brick becomes
   resident, and again when a face neighbour changes level or residency (render/bricks/BrickGradientCache.cpp).

   A brick at level l holds the words of its samples, i.e. of nodes o + 2^l i; each word is the central
   difference of the global node lattice at that node over the brick's sample spacing (nodes n +- 2^l;
   one-sided and halved at the grid's faces, as the grid cache), so a word on a brick face reads its
   neighbour's nodes, whatever their level. (Inside the brick that is the central difference of its own
   samples; over one node instead, the last sample's word would see the clamp of the node values beyond the
   brick's last sample, and the blend would carry that kink through the brick's last cell.) The gradient at a point
   is the trilinear blend of node gradients over the global lattice, as sample_volume blends node values: a
   level-0 node's gradient is its word; a node inside a level-l brick is the trilinear blend of that brick's
   words at (node - origin) / 2^l; a node of an absent brick (no ray reaches it or the TF hides it: its value is
   the stand-in) has no words and takes the central difference of the node lattice at sample time. Where all 8
   corners of a cell lie in one brick the blend reads 8 words of that brick (at level l: the cell of its
   coarse samples); only cells across a brick face into a coarse or absent brick pay for more. At level 0
   everywhere the words and the blend are those of the grid cache of the decoded volume, word for word. */
#ifndef VOLCL_BRICK_GRADIENT_CACHE_H
#define VOLCL_BRICK_GRADIENT_CACHE_H

#include "brick_sample.h"

/* The grid cache's format and helpers; this file provides the packet lookup itself. */
#define gcache_gradient8 volcl_grid_gcache_gradient8_unused
#include "gradient_cache.h"
#undef gcache_gradient8

/* Floats from a brick's samples to its words (pool header word 6). */
inline uint brick_words_delta(__global const float* pool) {
    return as_uint(pool[6]);
}

/* The world gradient of node differences (up - down) over 2s nodes per axis. */
inline float3 brick_difference_gradient(float3 d, uint s, const VolclGridParams* G) {
    return d * (0.5f / (float)s) * v3(G->invSpacing);
}

/* World gradient at full-resolution node n by central differences of the node lattice over s nodes (n +- s),
   one-sided (halved) at the grid's faces: what a node's cache word holds before packing (at s = 1 the grid's
   cache word on brick_node, gradient_cache.cl). */
inline float3 brick_node_gradient(__global const float* pool, const VolclGridParams* G, uint3 n, uint s) {
    const uint3 top = (uint3)(G->dims[0], G->dims[1], G->dims[2]) - 1u;
    const uint3 up = min(n + s, top);
    const uint3 dn = select(n - s, (uint3)(0u), n < s);
    const float gx =
        brick_node(pool, G, (uint3)(up.x, n.y, n.z)) - brick_node(pool, G, (uint3)(dn.x, n.y, n.z));
    const float gy =
        brick_node(pool, G, (uint3)(n.x, up.y, n.z)) - brick_node(pool, G, (uint3)(n.x, dn.y, n.z));
    const float gz =
        brick_node(pool, G, (uint3)(n.x, n.y, up.z)) - brick_node(pool, G, (uint3)(n.x, n.y, dn.z));
    return brick_difference_gradient((float3)(gx, gy, gz), s, G);
}

/* The trilinear blend of one brick's words at brick sample coordinates u (a level > 0 brick), in units of
   gradientMax. */
inline float3 brick_words_coarse(__global const float* pool, uint words, uint3 m, float3 u) {
    uint3 lo, hi;
    const float3 f = brick_cell(m, u, &lo, &hi);
    const uint8 o = brick_corner_offsets(m, lo, hi);
    const float3 c0 = gcache_unpack(as_uint(pool[words + o.s0])),
                 c1 = gcache_unpack(as_uint(pool[words + o.s1]));
    const float3 c2 = gcache_unpack(as_uint(pool[words + o.s2])),
                 c3 = gcache_unpack(as_uint(pool[words + o.s3]));
    const float3 c4 = gcache_unpack(as_uint(pool[words + o.s4])),
                 c5 = gcache_unpack(as_uint(pool[words + o.s5]));
    const float3 c6 = gcache_unpack(as_uint(pool[words + o.s6])),
                 c7 = gcache_unpack(as_uint(pool[words + o.s7]));
    const float3 c00 = c0 + f.x * (c1 - c0), c10 = c2 + f.x * (c3 - c2);
    const float3 c01 = c4 + f.x * (c5 - c4), c11 = c6 + f.x * (c7 - c6);
    const float3 a = c00 + f.y * (c10 - c00), b = c01 + f.y * (c11 - c01);
    return a + f.z * (b - a);
}

/* Node n's gradient as the blend sees it: its word when its brick is at level 0 (*word, *extra zero), else in
   *extra (world units): the coarse blend of its brick's words, or for an absent brick the sample-time
   central difference. */
inline void brick_node_word(__global const float* pool, const VolclGridParams* G, uint3 n, uint* word,
                            float3* extra) {
    const uint3 bsize = (uint3)(as_uint(pool[0]), as_uint(pool[1]), as_uint(pool[2]));
    const uint3 b = n / bsize;
    __global const float* e = pool + VOLCL_BRICK_HEADER + 4u * brick_index(pool, b);
    const uint level = as_uint(e[1]);
    *word = 0u;
    *extra = (float3)(0.0f);
    if (level == VOLCL_BRICK_ABSENT) {
        *extra = brick_node_gradient(pool, G, n, 1u);
        return;
    }
    const uint3 o = b * bsize;
    const uint3 m = brick_samples(G, bsize, o, level);
    const uint words = as_uint(e[0]) + brick_words_delta(pool);
    const uint3 l = n - o;
    if (level == 0u) {
        *word = as_uint(pool[words + (l.z * m.y + l.y) * m.x + l.x]);
        return;
    }
    *extra = brick_words_coarse(pool, words, m, convert_float3(l) * (1.0f / (float)(1u << level))) *
             G->gradientMax;
}

#if GRADIENT_CACHE == 2
/* World gradients of the packet at voxel points (px, py, pz): the nearest node's gradient. */
PACKET_INLINE void gcache_gradient8(__global const uint* cache, const VolclGridParams* G, float8 px,
                                    float8 py, float8 pz, float8* gx, float8* gy, float8* gz) {
    __global const float* pool = (__global const float*)cache;
    const int3 top = (int3)((int)G->dims[0] - 1, (int)G->dims[1] - 1, (int)G->dims[2] - 1);
    LaneF x, y, z, ex, ey, ez;
    LaneU w;
    x.v = px;
    y.v = py;
    z.v = pz;
    for (int l = 0; l < RAY_LANES; ++l) {
        const int3 i = clamp(convert_int3(rint((float3)(x.a[l], y.a[l], z.a[l]))), (int3)(0), top);
        float3 extra;
        brick_node_word(pool, G, convert_uint3(i), &w.a[l], &extra);
        ex.a[l] = extra.x;
        ey.a[l] = extra.y;
        ez.a[l] = extra.z;
    }
    gcache_unpack8(w.v, gx, gy, gz);
    *gx = *gx * G->gradientMax + ex.v;
    *gy = *gy * G->gradientMax + ey.v;
    *gz = *gz * G->gradientMax + ez.v;
}
#else
/* World gradients of the packet at voxel points (px, py, pz): the trilinear blend of node gradients over the
   global lattice (cells and clamps as sample_volume). Each lane gathers 8 words and its cell fractions; nodes
   without a word of their own (coarse or absent bricks, in cells across a face) add their share in world
   units. */
PACKET_INLINE void gcache_gradient8(__global const uint* cache, const VolclGridParams* G, float8 px,
                                    float8 py, float8 pz, float8* gx, float8* gy, float8* gz) {
    __global const float* pool = (__global const float*)cache;
    const int3 hiI = (int3)((int)G->dims[0] - 1, (int)G->dims[1] - 1, (int)G->dims[2] - 1);
    const uint3 bsize = (uint3)(as_uint(pool[0]), as_uint(pool[1]), as_uint(pool[2]));
    const uint delta = brick_words_delta(pool);
    LaneF x, y, z, fx, fy, fz, ex, ey, ez;
    LaneU w[8];
    x.v = px;
    y.v = py;
    z.v = pz;
    for (int l = 0; l < RAY_LANES; ++l) {
        const float3 p = clamp((float3)(x.a[l], y.a[l], z.a[l]), (float3)(0.0f), convert_float3(hiI));
        const int3 i0 = min(convert_int3(floor(p)), max(hiI - 1, (int3)(0)));
        const int3 i1 = min(i0 + 1, hiI);
        float3 f = p - convert_float3(i0);
        float3 extra = (float3)(0.0f);
        const uint3 u0 = convert_uint3(i0), u1 = convert_uint3(i1);
        const uint3 b = u0 / bsize;
        uint8 words = (uint8)(0u);
        if (all(u1 / bsize == b)) {
            __global const float* e = pool + VOLCL_BRICK_HEADER + 4u * brick_index(pool, b);
            const uint level = as_uint(e[1]);
            /* Inside an absent brick the value is its constant stand-in: no gradient (words stay 0). */
            if (level != VOLCL_BRICK_ABSENT) {
                const uint3 o = b * bsize;
                const uint3 m = brick_samples(G, bsize, o, level);
                __global const float* v = pool + as_uint(e[0]) + delta;
                uint3 lo = u0 - o, hi = u1 - o;
                if (level != 0u)
                    f = brick_cell(m, (p - convert_float3(o)) * (1.0f / (float)(1u << level)), &lo, &hi);
                const uint8 c = brick_corner_offsets(m, lo, hi);
                words = (uint8)(as_uint(v[c.s0]), as_uint(v[c.s1]), as_uint(v[c.s2]), as_uint(v[c.s3]),
                                as_uint(v[c.s4]), as_uint(v[c.s5]), as_uint(v[c.s6]), as_uint(v[c.s7]));
            }
        } else {
            const float wx0 = 1.0f - f.x, wy0 = 1.0f - f.y, wz0 = 1.0f - f.z;
            const float k[8] = {wx0 * wy0 * wz0, f.x * wy0 * wz0, wx0 * f.y * wz0, f.x * f.y * wz0,
                                wx0 * wy0 * f.z, f.x * wy0 * f.z, wx0 * f.y * f.z, f.x * f.y * f.z};
            uint wc[8];
            for (int c = 0; c < 8; ++c) {
                const uint3 n = (uint3)((c & 1) ? u1.x : u0.x, (c & 2) ? u1.y : u0.y, (c & 4) ? u1.z : u0.z);
                float3 g;
                brick_node_word(pool, G, n, &wc[c], &g);
                extra += k[c] * g;
            }
            words = (uint8)(wc[0], wc[1], wc[2], wc[3], wc[4], wc[5], wc[6], wc[7]);
        }
        gcache_set_lane(w, l, words);
        fx.a[l] = f.x;
        fy.a[l] = f.y;
        fz.a[l] = f.z;
        ex.a[l] = extra.x;
        ey.a[l] = extra.y;
        ez.a[l] = extra.z;
    }
    gcache_blend8(w, fx.v, fy.v, fz.v, G->gradientMax, gx, gy, gz);
    *gx += ex.v;
    *gy += ey.v;
    *gz += ez.v;
}
#endif

#endif
