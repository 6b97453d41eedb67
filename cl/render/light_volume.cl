/* Light-attenuation volumes (Weiskopf ch. 2, light propagation through slices): the optical depth toward a
   light at every node of a light grid, one slice per launch, swept away from the light. A node steps back
   along its ray toward the light to the previous slice, integrates the extinction over that segment (point
   sampled at S.step) and adds the previous slice's depth there (bicubic); a ray that leaves the box (or
   reaches a point light) before that slice integrates to there and starts from 0. Depth, not transmittance,
   is interpolated: it is linear where the medium is uniform, so slice after slice adds no bias there. */
#include "common/grid_sample.h"
#include "common/tf_lookup.h"

#pragma OPENCL FP_CONTRACT OFF

/* Catmull-Rom weights at fraction f of the interval between the middle two of four nodes. */
inline float4 catmull_rom(float f) {
    const float f2 = f * f, f3 = f2 * f;
    return (float4)(0.5f * (-f3 + 2.0f * f2 - f), 0.5f * (3.0f * f3 - 5.0f * f2 + 2.0f),
                    0.5f * (-3.0f * f3 + 4.0f * f2 + f), 0.5f * (f3 - f2));
}

/* Bicubic (Catmull-Rom) in a slice of w x h nodes at (u, v), clamped, at least 0: repeated bilinear lookups
   would blur a shadow's edge by a little more every slice (numerical diffusion); the cubic keeps it. */
inline float slice_cubic(__global const float* s, uint w, uint h, float u, float v) {
    const int wi = (int)w - 1, hi = (int)h - 1;
    u = clamp(u, 0.0f, (float)wi);
    v = clamp(v, 0.0f, (float)hi);
    const int u0 = min((int)floor(u), max(wi - 1, 0)), v0 = min((int)floor(v), max(hi - 1, 0));
    const float4 wu = catmull_rom(u - (float)u0), wv = catmull_rom(v - (float)v0);
    const float wua[4] = {wu.x, wu.y, wu.z, wu.w}, wva[4] = {wv.x, wv.y, wv.z, wv.w};
    float sum = 0.0f;
    for (int j = 0; j < 4; ++j) {
        const int y = clamp(v0 - 1 + j, 0, hi);
        float row = 0.0f;
        for (int i = 0; i < 4; ++i)
            row += wua[i] * s[y * (int)w + clamp(u0 - 1 + i, 0, wi)];
        sum += wva[j] * row;
    }
    return fmax(sum, 0.0f);
}

/* One slice: work-item (u, v) is the node with coordinate `slice` along S.axis, u along the next axis and v
   along the one after (cyclically). prev: the previous slice's optical depth, cur: this slice's, lv: the
   volume (nodes of this sweep only). */
__kernel void light_volume_slice(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                                 const VolclLightSweepParams S, __global const float* prev,
                                 __global float* cur, __global float* lv) {
    const uint a = S.axis, b = (a + 1u) % 3u, c = (a + 2u) % 3u;
    const uint mb = S.lv.dims[b], mc = S.lv.dims[c];
    const uint u = get_global_id(0), v = get_global_id(1);
    if (u >= mb || v >= mc) return;
    float na[3];
    na[a] = (float)S.slice;
    na[b] = (float)u;
    na[c] = (float)v;
    const float3 from = v3(S.fromLight), sp = v3(S.grid.spacing), inv = v3(S.grid.invSpacing);
    const float3 p = (float3)(na[0], na[1], na[2]) * from; /* voxel coordinates */
    float3 d;   /* voxel coordinates per world unit toward the light */
    float dist; /* world distance to the light */
    bool store = true;
    if (S.light[3] == VOLCL_LIGHT_POINT) {
        const float3 q = (v3(S.light) - v3(S.grid.origin)) * inv - p;
        const float3 qw = q * sp;
        dist = length(qw);
        d = dist > 0.0f ? q / dist : (float3)(0.0f);
        if (S.cone) {
            const float w[3] = {fabs(qw.x), fabs(qw.y), fabs(qw.z)};
            if (w[b] > w[a] + S.margin || w[c] > w[a] + S.margin) {
                cur[v * mb + u] = 0.0f; /* outside this pyramid: never read by a node inside it */
                return;
            }
            /* The node's own pyramid: its largest axis (ties to the lower axis) on its side of the light. */
            uint own = 0;
            for (uint k = 1; k < 3; ++k)
                if (w[k] > w[own]) own = k;
            store = own == a;
        }
    } else {
        d = v3(S.light) * inv;
        dist = INFINITY;
    }
    const float2 span = clip_box(p, d, grid_hi(&S.grid), 0.0f, dist);
    float tEnd = span.y > span.x ? fmax(span.y, 0.0f) : 0.0f;
    float depth = 0.0f;
    const float da[3] = {d.x, d.y, d.z}, pa[3] = {p.x, p.y, p.z}, fa[3] = {from.x, from.y, from.z};
    const float ta[3] = {S.lv.toLight[0], S.lv.toLight[1], S.lv.toLight[2]};
    if (S.slice != S.first && da[a] != 0.0f) {
        const float sPrev = (float)((int)S.slice - S.dir);
        const float tPrev = (sPrev * fa[a] - pa[a]) / da[a];
        /* The previous slice is reached inside the box and before the light (up to rounding at the box). */
        if (tPrev > 0.0f && tPrev <= tEnd + 1e-4f * tPrev) {
            tEnd = tPrev;
            const float3 x = p + tPrev * d;
            const float xa[3] = {x.x, x.y, x.z};
            depth = slice_cubic(prev, mb, mc, xa[b] * ta[b], xa[c] * ta[c]);
        }
    }
    if (tEnd > 0.0f) {
        const int n = max((int)ceil(tEnd / S.step), 1);
        const float h = tEnd / (float)n;
        for (int k = 0; k < n; ++k)
            depth +=
                tf_sample(knots, S.knotCount, sample_volume(vol, &S.grid, p + ((float)k + 0.5f) * h * d)).w *
                h;
    }
    cur[v * mb + u] = depth;
    if (store) {
        const uint i = (uint)na[0], j = (uint)na[1], k = (uint)na[2];
        lv[S.lightOffset + (k * S.lv.dims[1] + j) * S.lv.dims[0] + i] = depth;
    }
}
