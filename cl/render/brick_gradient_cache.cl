/* Builds the gradient-cache words of listed resident bricks (common/brick_gradient_cache.h), one work-item per
   sample of a brick, in the pool beside the samples. */
#include "common/brick_gradient_cache.h"

/* Work-item (s, j): sample s (x fastest over the full brick size) of brick bricks[j]; samples beyond the
   brick's level-l extent do nothing. The page table must already place every listed brick. */
__kernel void brick_gradient_build(__global float* pool, const VolclGridParams grid, __global const uint* bricks,
                                   uint count) {
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
    const uint3 n = o + (l << level);
    pool[as_uint(e[0]) + brick_words_delta(pool) + (l.z * m.y + l.y) * m.x + l.x] =
        as_float(gcache_pack(brick_node_gradient(pool, &grid, n, 1u << level), grid.gradientMax));
}
