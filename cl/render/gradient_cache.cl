/* Builds the gradient cache (common/gradient_cache.h): one packed central-difference gradient per voxel. */
#include "common/gradient_cache.h"

/* The raw differences vol[n + 1] - vol[n - 1] along each axis at voxel (x, y, z), clamped to the grid at its
   faces: the shared part of both cache forms. Exact for integer voxels (their floats and differences are). */
inline float3 voxel_differences(__global const voxel_t* vol, const VolclGridParams* G, uint x, uint y,
                                uint z) {
    const uint nx = G->dims[0], ny = G->dims[1], nz = G->dims[2], nxy = nx * ny;
    const size_t c = (size_t)z * nxy + (size_t)y * nx;
    const float gx = (float)vol[c + min(x + 1u, nx - 1u)] - (float)vol[c + (x > 0u ? x - 1u : 0u)];
    const size_t r = (size_t)z * nxy + x;
    const float gy = (float)vol[r + (size_t)min(y + 1u, ny - 1u) * nx] -
                     (float)vol[r + (size_t)(y > 0u ? y - 1u : 0u) * nx];
    const size_t s = (size_t)y * nx + x;
    const float gz = (float)vol[s + (size_t)min(z + 1u, nz - 1u) * nxy] -
                     (float)vol[s + (size_t)(z > 0u ? z - 1u : 0u) * nxy];
    return (float3)(gx, gy, gz);
}

__kernel void gradient_cache_build(__global const voxel_t* vol, const VolclGridParams grid,
                                   __global uint* cache) {
    const uint x = get_global_id(0), y = get_global_id(1), z = get_global_id(2);
    if (x >= grid.dims[0] || y >= grid.dims[1] || z >= grid.dims[2]) return;
    const size_t i = ((size_t)z * grid.dims[1] + y) * grid.dims[0] + x;
    const float3 d = voxel_differences(vol, &grid, x, y, z);
#ifdef GCACHE_EXACT
    cache[i] = gcache_pack_exact((int)d.x, (int)d.y, (int)d.z);
#else
    /* The world gradient by central differences, one-sided (halved) at the grid's faces: the gradient() of
       grid_sample.h at a voxel centre. */
    cache[i] = gcache_pack(d * 0.5f * v3(grid.invSpacing), grid.gradientMax);
#endif
}
