/* Discrete ray casting (Sereda ch. 4): each ray walks the voxels it crosses with a 3D DDA and takes each
   voxel's value for the whole segment inside it (nearest-voxel sampling), the cheapest preview tier. Host
   code and the C++ reference: render/grid/DiscreteRayCaster.cpp. */
#include "common/grid_sample.h"
#include "preview_table.h"

#pragma OPENCL FP_CONTRACT OFF

/* One work-item per pixel. The ray's part inside the grid's box [0, n - 1] is cut at the planes halfway
   between voxel centres (x = i + 1/2, ...); each piece is a segment of constant value, composited exactly:
   alpha = 1 - exp(-tau * length). */
__kernel void drc(__global const voxel_t* vol, __global const float4* table, const VolclCameraParams C,
                  const VolclGridParams G, const VolclPreviewTable T, __global float4* out) {
    const uint x = get_global_id(0), y = get_global_id(1);
    if (x >= C.width || y >= C.height) return;
    const Ray r = grid_ray(&G, camera_ray_world(&C, x, y));
    const float3 hi = grid_hi(&G);
    const float2 span = clip_box(r.o, r.d, hi, 0.0f, INFINITY);
    float3 color = (float3)(0.0f);
    float transmittance = 1.0f;
    if (span.y > span.x) {
        /* Scalars, not arrays indexed by the axis: PoCL keeps these in registers. */
        const float3 pe = r.o + span.x * r.d;
        const int nx = (int)G.dims[0], ny = (int)G.dims[1], nz = (int)G.dims[2];
        /* The voxel holding the entry point; a direction component's sign breaks the tie on a boundary. */
        const int3 i0 =
            clamp(convert_int3(floor(pe + sign(r.d) * 1e-4f + 0.5f)), (int3)(0), (int3)(nx, ny, nz) - 1);
        int ix = i0.x, iy = i0.y, iz = i0.z;
        const int3 st = select((int3)(-1), (int3)(1), r.d > 0.0f);
        const int sx = st.x, sy = st.y, sz = st.z;
        /* Ray parameter per voxel along each axis, and of the next cell boundary (infinite along axes the ray
           does not move on). */
        const float3 dt = select(1.0f / fabs(r.d), (float3)(INFINITY), r.d == 0.0f);
        const float3 tb = select((convert_float3(i0) + 0.5f * convert_float3(st) - r.o) / r.d,
                                 (float3)(INFINITY), r.d == 0.0f);
        const float dtx = dt.x, dty = dt.y, dtz = dt.z;
        float tx = tb.x, ty = tb.y, tz = tb.z;
        const int strideY = nx, strideZ = nx * ny;
        int at = iz * strideZ + iy * strideY + ix;
        float t = span.x;
        while (t < span.y) {
            const float tNext = fmin(tx, fmin(ty, tz));
            const float tEnd = fmin(tNext, span.y);
            const float4 e = preview_lookup(table, &T, (float)vol[at]);
            if (e.w > 0.0f) { /* transparent voxels cost only the walk */
                const float alpha = 1.0f - exp(-e.w * (tEnd - t));
                color += transmittance * alpha * e.xyz;
                transmittance *= 1.0f - alpha;
                if (1.0f - transmittance >= T.earlyTermination) break;
            }
            t = tEnd;
            if (tx == tNext) {
                ix += sx;
                if (ix < 0 || ix >= nx) break;
                at += sx;
                tx += dtx;
            } else if (ty == tNext) {
                iy += sy;
                if (iy < 0 || iy >= ny) break;
                at += sy * strideY;
                ty += dty;
            } else {
                iz += sz;
                if (iz < 0 || iz >= nz) break;
                at += sz * strideZ;
                tz += dtz;
            }
        }
    }
    out[(size_t)y * C.width + x] = (float4)(color, 1.0f - transmittance);
}
