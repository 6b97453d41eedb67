/* Builds the gradient-cache words of listed resident bricks (common/brick_gradient_cache.h), one work-item per
   sample of a brick, in the pool beside the samples. */
#include "common/brick_gradient_cache.h"

/* Work-item (s, j): sample s (x fastest over the full brick size) of brick bricks[j]; samples beyond the
   brick's level-l extent do nothing. The page table must already place every listed brick. */
__kernel void brick_gradient_build(__global float* pool, const VolclGridParams grid,
                                   __global const uint* bricks, uint count) {
    const uint s = get_global_id(0), j = get_global_id(1);
    const uint3 bsize = (uint3)(as_uint(pool[0]), as_uint(pool[1]), as_uint(pool[2]));
    if (j >= count || s >= bsize.x * bsize.y * bsize.z) return;
    const uint b = bricks[j];
    const uint gx = as_uint(pool[3]), gy = as_uint(pool[4]);
    const uint3 bc = (uint3)(b % gx, b / gx % gy, b / (gx * gy));
    __global const float* e = pool + VOLCL_BRICK_HEADER + 4u * b;
    const uint level = as_uint(e[1]);
    const uint3 o = bc * bsize;
    const uint3 m = brick_samples(&grid, bsize, o, level);
    const uint3 l = (uint3)(s % bsize.x, s / bsize.x % bsize.y, s / (bsize.x * bsize.y));
    if (any(l >= m)) return;
    const uint off = as_uint(e[0]), i = (l.z * m.y + l.y) * m.x + l.x;
    float3 g;
    if (all(l > 0u) && all(l + 1u < m)) {
        /* Both neighbours over the sample spacing are samples of this brick: the node values brick_node would
           return there (a trilinear lookup at a sample is the sample), read directly. */
        __global const float* v = pool + off + i;
        const int sy = (int)m.x, sz = (int)(m.x * m.y);
        g = brick_difference_gradient((float3)(v[1] - v[-1], v[sy] - v[-sy], v[sz] - v[-sz]), 1u << level,
                                      &grid);
    } else {
        g = brick_node_gradient(pool, &grid, o + (l << level), 1u << level);
    }
    pool[off + brick_words_delta(pool) + i] = as_float(gcache_pack(g, grid.gradientMax));
}
