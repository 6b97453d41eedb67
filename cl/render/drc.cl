/* Discrete ray casting (Sereda ch. 4): each ray walks the voxels it crosses with a 3D DDA and takes each
   voxel's value for the whole segment inside it (nearest-voxel sampling), the cheapest preview tier. Host
   code and the C++ reference: render/grid/DiscreteRayCaster.cpp. */
#include "common/grid_sample.h"
#include "preview_shared.h"

#pragma OPENCL FP_CONTRACT OFF

/* Straight (r, g, b, tau) of data value s, linear between the table's nodes. */
inline float4 drc_lookup(__global const float4* table, const VolclPreviewTable* T, float s) {
    const float x = clamp((s - T->lo) * T->scale, 0.0f, (float)(T->size - 1));
    const uint i = min((uint)x, T->size - 2);
    const float f = x - (float)i;
    return table[i] + f * (table[i + 1] - table[i]);
}

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
        const float o[3] = {r.o.x, r.o.y, r.o.z}, d[3] = {r.d.x, r.d.y, r.d.z};
        const float pe[3] = {r.o.x + span.x * r.d.x, r.o.y + span.x * r.d.y, r.o.z + span.x * r.d.z};
        int idx[3], stepI[3], n[3];
        float tNext[3], tDelta[3];
        for (int a = 0; a < 3; ++a) {
            n[a] = (int)G.dims[a];
            /* The voxel holding the entry point; a direction component's sign breaks the tie on a boundary. */
            const float e = pe[a] + (d[a] > 0.0f ? 1e-4f : d[a] < 0.0f ? -1e-4f : 0.0f);
            idx[a] = clamp((int)floor(e + 0.5f), 0, n[a] - 1);
            stepI[a] = d[a] > 0.0f ? 1 : -1;
            tDelta[a] = d[a] != 0.0f ? 1.0f / fabs(d[a]) : INFINITY;
            tNext[a] = d[a] != 0.0f ? ((float)idx[a] + 0.5f * (float)stepI[a] - o[a]) / d[a] : INFINITY;
        }
        const uint nx = G.dims[0], nxy = G.dims[0] * G.dims[1];
        float t = span.x;
        while (t < span.y) {
            const int a = tNext[0] <= tNext[1] ? (tNext[0] <= tNext[2] ? 0 : 2) : (tNext[1] <= tNext[2] ? 1 : 2);
            const float tEnd = fmin(tNext[a], span.y);
            const float s = (float)vol[(uint)idx[2] * nxy + (uint)idx[1] * nx + (uint)idx[0]];
            const float4 e = drc_lookup(table, &T, s);
            const float alpha = 1.0f - exp(-e.w * (tEnd - t));
            color += transmittance * alpha * e.xyz;
            transmittance *= 1.0f - alpha;
            if (1.0f - transmittance >= T.earlyTermination) break;
            t = tEnd;
            idx[a] += stepI[a];
            if (idx[a] < 0 || idx[a] >= n[a]) break;
            tNext[a] += tDelta[a];
        }
    }
    out[(size_t)y * C.width + x] = (float4)(color, 1.0f - transmittance);
}
