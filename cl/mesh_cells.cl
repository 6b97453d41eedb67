/* Exact cell ray casting of a tetrahedral mesh: rays enter at boundary faces (a BVH of them), walk
   face-adjacent tets leaving each through the nearest face plane ahead, and re-enter after leaving a
   non-convex mesh. Each cell segment has a linear scalar: dvr looks it up in the 3D pre-integration table
   (PREINT 3) or point-samples it every render.step (no PREINT); iso crossings are exact; mip takes the
   segment ends; xray integrates tau exactly. Everything runs in the mesh's normalised frame (VolclMeshParams).
   Defines: MODE (0 dvr, 1 mip, 2 iso, 3 xray), MIP_COLOR, PREINT, ISO_COUNT, SHADING, CLIPPING, SKIPPING,
   EARLY_TERMINATION. */
#include "common/camera_rays.h"
#include "common/shading.h"
#include "common/tf_lookup.h"

#pragma OPENCL FP_CONTRACT OFF

#define NO_FACE 0xFFFFFFFFu
#define MAX_ENTRIES 256
#define MAX_STEPS (1u << 22)
#define RECENT 4

#ifndef MODE
#define MODE 0
#endif

/* Buffers, in one struct so helpers take one pointer. */
typedef struct {
    __global const float4* planes;    /* 4 per tet: outward normal n and w, n.x + w = 0 on the face */
    __global const float4* fields;    /* per tet: gradient g and c, s(x) = g.x + c */
    __global const uint4* neighbors;  /* per tet: the face across each face (tet * 4 + face), NO_FACE */
    __global const uchar* empty;      /* per tet: 1 when nothing it holds can show */
    __global const float4* bvhNodes;  /* 2 per node: lo (w: first or right child), hi (w: leaf count) */
    __global const float4* bvhFaces;  /* 3 per leaf face: vertex a (w: face id), edge b - a, edge c - a */
    __global const VolclTfKnot* knots;
    __global const float* tauIntegral; /* per knot: integral of tau from knot 0 to it */
    __global const float4* table;
} MeshData;

typedef struct {
    float t;
    uint face;
} Entry;

/* The nearest entering boundary face (outward normal against d) hit at t >= tMin, skipping `recent`. */
inline Entry first_entry(const MeshData* M, const VolclMeshParams* P, float3 o, float3 d, float tMin,
                         const uint* recent) {
    Entry best;
    best.t = INFINITY;
    best.face = NO_FACE;
    if (P->bvhNodes == 0) return best;
    const float3 inv = (float3)(1.0f) / d;
    uint stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const uint ni = stack[--top];
        const float4 lo = M->bvhNodes[2 * ni], hi = M->bvhNodes[2 * ni + 1];
        const float3 u = (lo.xyz - o) * inv, v = (hi.xyz - o) * inv;
        const float3 mn = fmin(u, v), mx = fmax(u, v);
        /* NaN from 0 * inf (a ray in a slab plane) is dropped by fmax/fmin, keeping the other bound. */
        const float pad = 1e-6f;
        const float t0 = fmax(fmax(fmax(mn.x, mn.y), mn.z) - pad, tMin);
        const float t1 = fmin(fmin(fmin(mx.x, mx.y), mx.z) + pad, best.t);
        if (t0 > t1) continue;
        const uint count = as_uint(hi.w);
        if (count == 0) {
            if (top < 62) {
                stack[top++] = as_uint(lo.w);
                stack[top++] = ni + 1;
            }
            continue;
        }
        const uint first = as_uint(lo.w);
        for (uint i = first; i < first + count; ++i) {
            const float4 a = M->bvhFaces[3 * i], e1 = M->bvhFaces[3 * i + 1], e2 = M->bvhFaces[3 * i + 2];
            const uint face = as_uint(a.w);
            bool skip = false;
            for (int r = 0; r < RECENT; ++r) skip |= recent[r] == face;
            if (skip) continue;
            const float3 n = cross(e1.xyz, e2.xyz);
            if (!(dot(n, d) < 0.0f)) continue;
            const float3 p = cross(d, e2.xyz);
            const float det = dot(e1.xyz, p);
            if (det == 0.0f) continue;
            const float invDet = 1.0f / det;
            const float3 s = o - a.xyz;
            const float bu = dot(s, p) * invDet;
            const float tol = 1e-5f;
            if (bu < -tol || bu > 1.0f + tol) continue;
            const float3 q = cross(s, e1.xyz);
            const float bv = dot(d, q) * invDet;
            if (bv < -tol || bu + bv > 1.0f + tol) continue;
            const float t = dot(e2.xyz, q) * invDet;
            if (t >= tMin && t < best.t) {
                best.t = t;
                best.face = face;
            }
        }
    }
    return best;
}

/* Per-ray compositing state. */
typedef struct {
    float3 rgb;
    float alpha;
    float depth;  /* world distance to the first iso-surface */
    float mip;
    float xray;   /* optical depth */
    int inside;
    float nextSample; /* point sampling: normalised t of the next sample */
} RayState;

inline float tau_integral_at(const MeshData* M, uint count, float s) {
    const uint k = tf_find_interval(M->knots, count, s);
    __global const VolclTfKnot* kn = M->knots + k;
    const float d = fmin(s - kn->s, FLT_MAX);
    const float slope = d > 0.0f ? kn->slope[3] : 0.0f;
    return M->tauIntegral[k] + d * kn->value[3] + 0.5f * d * d * slope;
}

/* Integral of tau over a segment of world length len with s linear from sa to sb. */
inline float segment_depth(const MeshData* M, const VolclTfParams* T, float sa, float sb, float len) {
    const float span = T->domainHi - T->domainLo;
    if (fabs(sb - sa) <= 1e-4f * span) return tf_sample(M->knots, T->knotCount, 0.5f * (sa + sb)).w * len;
    return (tau_integral_at(M, T->knotCount, sb) - tau_integral_at(M, T->knotCount, sa)) / (sb - sa) * len;
}

/* Lit colour of straight colour c as K c + S (affine in c) for a sample at normalised x with the tet's
   normalised gradient g. */
inline void light_affine(const VolclLightingParams* Lp, const VolclCameraParams* C, float3 eye, float3 rayDir,
                         float3 x, float3 g, float3* K, float3* S) {
#ifdef SHADING
    LightSum ls = light_begin(Lp, g, rayDir);
    for (uint i = 0; i < Lp->lightCount; ++i) {
        float dist;
        const float3 L = light_dir(Lp, C->perspective, eye, rayDir, (int)i, x, &dist);
        light_add(&ls, Lp, (int)i, L, 1.0f, rayDir);
    }
    *S = light_finish(&ls, Lp, (float3)(0.0f));
    *K = light_finish(&ls, Lp, (float3)(1.0f)) - *S;
#else
    *K = (float3)(1.0f);
    *S = (float3)(0.0f);
#endif
}

inline void composite(RayState* st, float3 rgb, float a) {
    const float w = 1.0f - st->alpha;
    st->rgb += w * rgb;
    st->alpha += w * a;
}

/* DVR over the normalised ray interval [ta, tb] of one tet with s from sa to sb. */
inline void dvr_piece(const MeshData* M, const VolclMeshRenderParams* Pc, const VolclTfParams* T,
                      const VolclLightingParams* Lp, const VolclCameraParams* C, float3 eye, float3 o, float3 d,
                      float ta, float tb, float sa, float sb, float3 g, RayState* st) {
    if (!(tb > ta)) return;
    const float scale = Pc->mesh.scale;
#if PREINT == 3
    const float len = (tb - ta) * scale;
    const float maxLen = Pc->mesh.maxSegment;
    const int n = len > maxLen ? (int)ceil(len / maxLen) : 1;
    const float sub = len / (float)n;
    float3 K = (float3)(1.0f), S = (float3)(0.0f);
#ifdef SHADING
    light_affine(Lp, C, eye, d, o + (0.5f * (ta + tb)) * d, g, &K, &S);
#endif
    for (int i = 0; i < n; ++i) {
        const float u0 = (float)i / (float)n, u1 = (float)(i + 1) / (float)n;
        const float4 e = preint_segment(M->table, T, sa + (sb - sa) * u0, sb + (sa - sb) * (1.0f - u1), sub);
        composite(st, K * e.xyz + S * e.w, e.w);
    }
#else
    /* Point sampling on the ray's lattice nextSample + k * step (normalised), alpha from tau * step. */
    const float h = Pc->march.step * Pc->mesh.invScale;
    float ts = st->nextSample;
    if (ts < ta) ts += ceil((ta - ts) / h) * h;
    for (; ts < tb; ts += h) {
        const float u = (ts - ta) / (tb - ta);
        const float s = sa + (sb - sa) * u;
        const float4 v = tf_sample(M->knots, T->knotCount, s);
        const float a = 1.0f - exp(-v.w * Pc->march.step);
        if (a > 0.0f) {
            float3 K = (float3)(1.0f), S = (float3)(0.0f);
#ifdef SHADING
            light_affine(Lp, C, eye, d, o + ts * d, g, &K, &S);
#endif
            composite(st, (K * v.xyz + S) * a, a);
        }
    }
    st->nextSample = ts;
#endif
}

/* The part [ta, tb] (normalised) of the ray inside tet `tet`. */
inline void cell_segment(const MeshData* M, const VolclMeshRenderParams* Pc, const VolclTfParams* T,
                         const VolclLightingParams* Lp, const VolclCameraParams* C, float3 eye, float3 o, float3 d,
                         float tOffset, uint tet, float ta, float tb, float2 clip, RayState* st) {
    const float a = fmax(ta, clip.x), b = fmin(tb, clip.y);
    if (!(b >= a)) return;
#if defined(SKIPPING) && (MODE == 0 || MODE == 2)
    if (M->empty[tet]) return; /* point sampling: dvr_piece moves the lattice on to the next tet */
#endif
    const float4 f = M->fields[tet];
    const float sa = dot(f.xyz, o + a * d) + f.w, sb = dot(f.xyz, o + b * d) + f.w;
#if MODE == 1
    st->mip = fmax(st->mip, fmax(sa, sb));
    st->inside = 1;
#elif MODE == 3
    if (b > a) st->xray += segment_depth(M, T, sa, sb, (b - a) * Pc->mesh.scale);
#else
    if (!(b > a)) return;
    float u0 = 0.0f;
#if ISO_COUNT > 0
    /* Crossings inside the segment, in ray order. */
    float us[ISO_COUNT];
    int ids[ISO_COUNT];
    int nc = 0;
    for (int i = 0; i < (int)Pc->iso.count; ++i) {
        const float v = Pc->iso.value[i];
        if ((sa >= v) != (sb >= v)) {
            float u = clamp((v - sa) / (sb - sa), 0.0f, 1.0f);
            int j = nc++;
            while (j > 0 && us[j - 1] > u) {
                us[j] = us[j - 1];
                ids[j] = ids[j - 1];
                --j;
            }
            us[j] = u;
            ids[j] = i;
        }
    }
    for (int c = 0; c < nc; ++c) {
        const float u = us[c];
#if MODE == 0
        dvr_piece(M, Pc, T, Lp, C, eye, o, d, a + (b - a) * u0, a + (b - a) * u, sa + (sb - sa) * u0,
                  sa + (sb - sa) * u, f.xyz, st);
#endif
        u0 = u;
        const int i = ids[c];
        const float t = a + (b - a) * u;
        float3 K, S;
        light_affine(Lp, C, eye, d, o + t * d, f.xyz, &K, &S);
        const float3 ic = (float3)(Pc->iso.color[i][0], Pc->iso.color[i][1], Pc->iso.color[i][2]);
        const float ia = Pc->iso.color[i][3];
        if (isinf(st->depth)) st->depth = (tOffset + t) * Pc->mesh.scale;
        composite(st, (K * ic + S) * ia, ia);
    }
#endif
#if MODE == 0
    dvr_piece(M, Pc, T, Lp, C, eye, o, d, a + (b - a) * u0, b, sa + (sb - sa) * u0, sb, f.xyz, st);
#endif
#endif
}

__kernel void mesh_cells(__global const float4* planes, __global const float4* fields,
                         __global const uint4* neighbors, __global const uchar* empty,
                         __global const float4* bvhNodes, __global const float4* bvhFaces,
                         __global const VolclTfKnot* knots, __global const float* tauIntegral,
                         __global const float4* table, const VolclMeshRenderParams params,
                         __global float4* out, __global float* depthOut) {
    const VolclMeshRenderParams* Pc = &params;
    const uint x = get_global_id(0), y = get_global_id(1);
    const VolclCameraParams C = Pc->camera;
    if (x >= C.width || y >= C.height) return;
    const size_t pixel = (size_t)y * C.width + x;
    MeshData M = {planes, fields, neighbors, empty, bvhNodes, bvhFaces, knots, tauIntegral, table};
    const VolclMeshParams P = Pc->mesh;
    const VolclTfParams T = Pc->tf;
    const VolclLightingParams Lp = Pc->lighting;
    const VolclClipParams K = Pc->clip;

    /* The camera ray in the normalised frame, its origin moved to where it meets the mesh box. */
    WorldRay wr = camera_ray_world(&C, x, y);
    float3 o = (wr.o - v3(P.centre)) * P.invScale;
    const float3 d = wr.d;
    const float3 eye = (v3(C.origin) - v3(P.centre)) * P.invScale;
    const float3 inv = (float3)(1.0f) / d;
    const float3 u = (v3(P.boxLo) - o) * inv, v = (v3(P.boxHi) - o) * inv;
    const float3 mn = fmin(u, v), mx = fmax(u, v);
    const float tBox0 = fmax(fmax(fmax(mn.x, mn.y), mn.z), 0.0f);
    const float tBox1 = fmin(fmin(mx.x, mx.y), mx.z);
    RayState st;
    st.rgb = (float3)(0.0f);
    st.alpha = 0.0f;
    st.depth = INFINITY;
    st.mip = -INFINITY;
    st.xray = 0.0f;
    st.inside = 0;
    st.nextSample = 0.0f;
    if (tBox1 >= tBox0) {
        /* Relative parameters near the mesh keep float precision for far cameras. */
        const float tOffset = fmax(tBox0 - 1e-3f, 0.0f);
        o += tOffset * d;
        float2 clip = (float2)(-INFINITY, INFINITY);
#ifdef CLIPPING
        clip_planes(&K, o, d, &clip);
#endif
        uint recent[RECENT] = {NO_FACE, NO_FACE, NO_FACE, NO_FACE};
        int ri = 0;
        float tMin = 0.0f;
        uint steps = 0;
        bool first = true;
        bool done = !(clip.y > clip.x);
        for (int e = 0; e < MAX_ENTRIES && !done; ++e) {
            const Entry hit = first_entry(&M, &P, o, d, tMin - P.epsilon, recent);
            if (hit.face == NO_FACE || hit.t > clip.y) break;
            recent[ri] = hit.face;
            ri = (ri + 1) % RECENT;
            uint tet = hit.face >> 2, entered = hit.face & 3u;
            float t = hit.t;
            if (first) {
                /* The point-sampling lattice starts half a step into the mesh. */
                st.nextSample = fmax(t, clip.x) + 0.5f * Pc->march.step * P.invScale;
                first = false;
            }
            for (; steps < MAX_STEPS; ++steps) {
                float best = INFINITY, steepestNd = -INFINITY;
                uint exitFace = 4, steepest = 0;
                for (uint fi = 0; fi < 4; ++fi) {
                    if (fi == entered) continue;
                    const float4 pl = planes[4 * tet + fi];
                    const float nd = dot(pl.xyz, d);
                    if (nd > steepestNd) {
                        steepestNd = nd;
                        steepest = fi;
                    }
                    if (!(nd > 0.0f)) continue;
                    const float tf = -(dot(pl.xyz, o) + pl.w) / nd;
                    if (tf < best) {
                        best = tf;
                        exitFace = fi;
                    }
                }
                if (exitFace == 4) {
                    exitFace = steepest;
                    best = t;
                }
                const float tExit = fmax(best, t);
                cell_segment(&M, Pc, &T, &Lp, &C, eye, o, d, tOffset, tet, t, tExit, clip, &st);
                t = tExit;
#if defined(EARLY_TERMINATION) && (MODE == 0 || MODE == 2)
                if (st.alpha >= Pc->march.earlyTermination) {
                    done = true;
                    break;
                }
#endif
                if (t > clip.y) {
                    done = true;
                    break;
                }
                const uint nb = ((__global const uint*)(neighbors + tet))[exitFace];
                if (nb == NO_FACE) break;
                tet = nb >> 2;
                entered = nb & 3u;
            }
            if (steps >= MAX_STEPS) break;
            tMin = t;
        }
    }
    float4 result;
#if MODE == 1
    if (!st.inside) {
        result = (float4)(0.0f);
    } else {
        const float m = st.mip;
#if MIP_COLOR == 2
        const float4 tv = tf_sample(knots, T.knotCount, m);
        const float a = 1.0f - exp(-tv.w);
        result = (float4)(tv.xyz * a, a);
#else
        const float g = clamp((m - Pc->march.windowLo) * Pc->march.windowInvWidth, 0.0f, 1.0f);
#if MIP_COLOR == 1
        const float4 tv = tf_sample(knots, T.knotCount, m);
        result = (float4)(tv.xyz * g, g);
#else
        result = (float4)(g, g, g, g);
#endif
#endif
    }
#elif MODE == 3
    {
        const float a = -expm1(-st.xray);
        result = (float4)(a, a, a, a);
    }
#else
    result = (float4)(st.rgb, st.alpha);
#endif
    out[pixel] = result;
    depthOut[pixel] = st.depth;
}
