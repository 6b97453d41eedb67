/* Shear-warp (Lacroute and Levoy 1994; Sereda ch. 5): slices of a run-length-encoded classified volume are
   sheared into an intermediate image and composited front to back, then the intermediate image is warped
   into the final image. Host code and the C++ reference: render/grid/ShearWarp.cpp. */
#include "common/grid_sample.h"
#include "preview_table.h"

#pragma OPENCL FP_CONTRACT OFF

/* The first pixel at or after u that is not yet opaque: links[u] == u for such pixels, links[W] == W ends
   the scanline. Path compression keeps later searches short (Lacroute's opaque pixel links). */
inline uint next_open(__global uint* links, uint u) {
    uint root = u;
    while (links[root] != root)
        root = links[root];
    while (links[u] != root && u != root) {
        const uint next = links[u];
        links[u] = root;
        u = next;
    }
    return root;
}

/* One work-item per intermediate scanline v: clears it, then composites every slice's runs of
   non-transparent cells front to back, sampling each cell bilinearly at the scanline's pixels and skipping
   pixels that are already opaque. rowRuns[k * (nb - 1) + j] .. rowRuns[... + 1] are the runs of cell row j
   (voxel rows j and j + 1) of slice k; a run (first cell, cells n, data offset) stores rows j and j + 1 of
   its n + 1 voxels one after the other in data. links: (W + 1) entries per scanline. */
__kernel void shearwarp_composite(__global const uint* rowRuns, __global const uint4* runs,
                                  __global const float* data, __global const float4* table,
                                  const VolclShearWarpParams P, __global float4* inter,
                                  __global uint* links) {
    const uint v = get_global_id(0);
    const uint W = P.inter[0], H = P.inter[1];
    if (v >= H) return;
    __global float4* row = inter + (size_t)v * W;
    __global uint* link = links + (size_t)v * (W + 1);
    for (uint u = 0; u <= W; ++u)
        link[u] = u;
    for (uint u = 0; u < W; ++u)
        row[u] = (float4)(0.0f);
    const uint nc = P.dims[0], na = P.dims[1], nb = P.dims[2];
    /* A slab of zero thickness (one slice) or of zero area (na or nb is 1) shows nothing, as a ray marcher's
       zero-length path through it. */
    if (nc < 2 || na < 2 || nb < 2) return;
    const VolclPreviewTable T = P.table;
    for (uint kk = 0; kk < nc; ++kk) {
        const uint k = P.axis[3] ? kk : nc - 1 - kk;
        const float bf = (float)v - P.shear[3] - P.shear[1] * (float)k;
        if (!(bf >= 0.0f && bf <= (float)(nb - 1))) continue;
        const uint j = min((uint)bf, nb - 2);
        const float fy = bf - (float)j;
        /* End slices stand for half a slab: the integral runs from the first slice to the last. */
        __global const float4* tab = table + ((k == 0 || k == nc - 1) ? T.size : 0);
        const float shiftA = P.shear[2] + P.shear[0] * (float)k;
        const uint cellRow = k * (nb - 1) + j;
        for (uint r = rowRuns[cellRow]; r < rowRuns[cellRow + 1]; ++r) {
            const uint4 run = runs[r];
            const float first = (float)run.x + shiftA;
            const int uLast = min((int)floor(first + (float)run.y), (int)W - 1);
            if (uLast < 0) continue;
            uint u = next_open(link, (uint)max((int)ceil(first), 0));
            __global const float* row0 = data + run.z;
            __global const float* row1 = row0 + run.y + 1;
            while ((int)u <= uLast) {
                const float ia = clamp((float)u - first, 0.0f, (float)run.y);
                const uint x = min((uint)ia, run.y - 1);
                const float fx = ia - (float)x;
                const float s0 = row0[x] + fx * (row0[x + 1] - row0[x]);
                const float s1 = row1[x] + fx * (row1[x + 1] - row1[x]);
                const float4 e = preview_lookup(tab, &T, s0 + fy * (s1 - s0));
                float4 c = row[u];
                c += (1.0f - c.w) * e;
                row[u] = c;
                if (c.w >= T.earlyTermination) link[u] = u + 1;
                u = next_open(link, u + 1);
            }
        }
    }
}

/* One work-item per final pixel: the pixel's ray meets slice plane c = 0 at intermediate coordinates
   (a + offA, b + offB); the intermediate image is sampled there bilinearly (transparent outside it). */
__kernel void shearwarp_warp(__global const float4* inter, const VolclShearWarpParams P,
                             const VolclCameraParams C, const VolclGridParams G, __global float4* out) {
    const uint x = get_global_id(0), y = get_global_id(1);
    if (x >= C.width || y >= C.height) return;
    const Ray r = grid_ray(&G, camera_ray_world(&C, x, y));
    const float o[3] = {r.o.x, r.o.y, r.o.z}, d[3] = {r.d.x, r.d.y, r.d.z};
    const uint c = P.axis[0], a = P.axis[1], b = P.axis[2];
    const float t = -o[c] / d[c];
    float pa = o[a] + t * d[a] + P.shear[2], pb = o[b] + t * d[b] + P.shear[3];
    const int W = (int)P.inter[0], H = (int)P.inter[1];
    /* Clamped so far-away coordinates stay in int range; any point outside the image is transparent. */
    pa = clamp(pa, -2.0f, (float)W + 1.0f);
    pb = clamp(pb, -2.0f, (float)H + 1.0f);
    const float fa = floor(pa), fb = floor(pb);
    const int ia = (int)fa, ib = (int)fb;
    const float wa = pa - fa, wb = pb - fb;
    float4 acc = (float4)(0.0f);
    for (int db = 0; db < 2; ++db)
        for (int da = 0; da < 2; ++da) {
            const int ua = ia + da, vb = ib + db;
            if (ua < 0 || vb < 0 || ua >= W || vb >= H) continue;
            const float w = (da ? wa : 1.0f - wa) * (db ? wb : 1.0f - wb);
            acc += w * inter[(size_t)vb * (size_t)W + (size_t)ua];
        }
    out[(size_t)y * C.width + x] = acc;
}
