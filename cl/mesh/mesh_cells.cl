/* Exact cell ray casting of a tetrahedral mesh: rays enter at boundary faces (a BVH of them), walk
   face-adjacent tets leaving each through the nearest face plane ahead, and re-enter after leaving a
   non-convex mesh; a ray already inside (camera in the mesh) starts in the tet found by walking back from the
   boundary face it leaves by. Where tets may overlap (MESH_OVERLAPS) a ray walks from every entry along its line
   and counts the union of the walks' intervals. Each cell segment has a linear scalar: dvr
   looks it up in the 3D pre-integration table (PREINT 3) or point-samples it every render.step (no PREINT);
   iso crossings are exact; mip takes the segment ends; xray integrates tau and emission c tau exactly. Everything runs in the
   mesh's normalised frame (VolclMeshParams).
   Defines: MODE (0 dvr, 1 mip, 2 iso, 3 xray, 4 emission), MIP_COLOR, PREINT, ISO_COUNT, SHADING, CLIPPING, SKIPPING,
   EARLY_TERMINATION, SMOOTH_NORMALS (shading takes the tet's interpolated vertex normals, `normals`, instead of
   its constant gradient), MESH_OVERLAPS (tets may overlap: folded tets, interpenetrating components; see
   ray_advance), NAN_COLOR (the mesh has NaN cells, marked by a NaN field; NAN_R/G/B/TAU: the NaN
   colour). */
#include "common/camera_rays.h"
#include "common/iso_crossings.h"
#include "common/shading.h"
#include "common/tf_lookup.h"

#pragma OPENCL FP_CONTRACT OFF

#define NO_FACE 0xFFFFFFFFu
#define MAX_ENTRIES 256
#define MAX_STEPS (1u << 22)
#define RECENT 4
#define CELL_STRIDE 6

#ifndef MODE
#define MODE 0
#endif

/* Unshaded pre-integrated dvr merges runs of short segments into one lookup (see dvr_piece). */
#if MODE == 0 && PREINT == 3 && !defined(SHADING) && !(ISO_COUNT > 0)
#define MERGE_SEGMENTS
#ifndef MERGE_TOL
#define MERGE_TOL 0.5f /* in table node spacings of the scalar */
#endif
#endif

/* Buffers, in one struct so helpers take one pointer. */
typedef struct {
    /* 6 per tet, one tet's data in 96 contiguous bytes (the walk is latency bound): 4 face planes (outward
       normal n and w, n.x + w = 0 on the face), the linear field (gradient g and c, s(x) = g.x + c), and the
       face across each face (tet * 4 + face, NO_FACE on the boundary, VOLCL_MESH_HULL_FACE on the convex hull)
       as uint bits. */
    __global const float4* cells;
    __global const uchar* empty;     /* per tet: 1 when nothing it holds can show */
    __global const float4* bvhNodes; /* 2 per node: lo (w: first or right child), hi (w: leaf count) */
    __global const float4* bvhFaces; /* 3 per leaf face: vertex a (w: face id), edge b - a (w: 1 on the convex
                                         hull), edge c - a */
    __global const VolclTfKnot* knots;
    __global const float* tauIntegral; /* per knot: integral of tau from knot 0 to it */
    __global const float4* table;
    /* SMOOTH_NORMALS: 3 per tet, component c of the interpolated vertex normal at normalised x is
       dot(n[c].xyz, x) + n[c].w (render/mesh/VertexNormals.hpp); otherwise unused. */
    __global const float4* normals;
} MeshData;

typedef struct {
    float t;
    uint face;
    uint leaf;    /* the face's index in bvhFaces */
    int entering; /* 0: the ray leaves the mesh by the face (it was inside before it) */
} Entry;

/* Ray parameter interval [x, y] of node ni's box within [tMin, tMax] (empty when x > y), padded so faces lying
   in a box plane are not lost to rounding; NaN from 0 * inf (a ray in a slab plane) is dropped by fmin/fmax. */
inline float2 slab(const MeshData* M, uint ni, float3 o, float3 inv, float tMin, float tMax) {
    const float4 lo = M->bvhNodes[2 * ni], hi = M->bvhNodes[2 * ni + 1];
    const float3 u = (lo.xyz - o) * inv, v = (hi.xyz - o) * inv;
    const float3 mn = fmin(u, v), mx = fmax(u, v);
    const float pad = 1e-6f;
    return (float2)(fmax(fmax(fmax(mn.x, mn.y), mn.z) - pad, tMin),
                    fmin(fmin(fmin(mx.x, mx.y), mx.z) + pad, tMax));
}

/* The leaf's faces first..first+count-1: keeps the nearest entering hit at t >= tMin or leaving hit at
   t > tExitMin in *best (tExitMin INFINITY: entering faces only, the others culled before the hit test).
   MESH_OVERLAPS: entering faces of tets that overlap others (marked in the third record's w) count from
   tOverlap on. */
inline void leaf_faces(const MeshData* M, uint first, uint count, float3 o, float3 d, float tMin,
                       float tExitMin, float tOverlap, const uint* recent, Entry* best) {
    for (uint i = first; i < first + count; ++i) {
        const float4 a = M->bvhFaces[3 * i], e1 = M->bvhFaces[3 * i + 1], e2 = M->bvhFaces[3 * i + 2];
        const uint face = as_uint(a.w);
        bool skip = false;
        for (int r = 0; r < RECENT; ++r)
            skip |= recent[r] == face;
        if (skip) continue;
        const float3 n = cross(e1.xyz, e2.xyz);
        const float nd = dot(n, d);
        const int entering = nd < 0.0f;
        if (!entering && !(nd > 0.0f && tExitMin < INFINITY)) continue;
#ifdef MESH_OVERLAPS
        const float tEnter = e2.w != 0.0f ? tOverlap : tMin;
#else
        const float tEnter = tMin;
#endif
        const float3 s = o - a.xyz;
        /* The plane's t first (a little slack for rounding): most faces of a visited leaf lie behind the best hit
           or before the search's start, and need no triangle test. */
        const float tPlane = -dot(n, s) / nd;
        if (!(tPlane <= best->t + 1e-5f && tPlane >= (entering ? tEnter : tExitMin) - 1e-5f)) continue;
        const float3 p = cross(d, e2.xyz);
        const float det = dot(e1.xyz, p);
        if (det == 0.0f) continue;
        const float invDet = 1.0f / det;
        const float bu = dot(s, p) * invDet;
        const float tol = 1e-5f;
        if (bu < -tol || bu > 1.0f + tol) continue;
        const float3 q = cross(s, e1.xyz);
        const float bv = dot(d, q) * invDet;
        if (bv < -tol || bu + bv > 1.0f + tol) continue;
        const float t = dot(e2.xyz, q) * invDet;
        if ((entering ? t >= tEnter : t > tExitMin) && t < best->t) {
            best->t = t;
            best->face = face;
            best->leaf = i;
            best->entering = entering;
        }
    }
}

/* The nearest boundary face hit: entering (outward normal against d) at t >= tMin or leaving at t > tExitMin,
   skipping `recent` (MESH_OVERLAPS: entering faces of overlapping tets at t >= tOverlap). A leaving face first
   means the ray is inside the mesh before it.
   `seed` (a bvhFaces index or NO_FACE) is the face a neighbouring ray entered by: neighbouring rays usually
   enter by the same or a nearby face, and a hit there bounds the search to the nodes in front of it. */
inline Entry first_entry(const MeshData* M, const VolclMeshParams* P, float3 o, float3 d, float tMin,
                         float tExitMin, float tOverlap, const uint* recent, uint seed) {
    Entry best;
    best.t = INFINITY;
    best.face = NO_FACE;
    best.leaf = NO_FACE;
    best.entering = 1;
    if (P->bvhNodes == 0) return best;
    if (seed != NO_FACE) {
        leaf_faces(M, seed, 1, o, d, tMin, tExitMin, tOverlap, recent, &best);
        /* Entering a hull face, the ray was outside the face's plane, which has the whole mesh on its inner side,
           all the way before the hit: no face can be nearer. */
        if (best.face != NO_FACE && best.entering && M->bvhFaces[3 * seed + 1].w != 0.0f) return best;
    }
    const float tLow = fmin(tMin, tExitMin); /* the boxes' lower bound */
#ifdef MESH_OVERLAPS
    /* Boxes holding faces of overlapping tets from tOverlap on. */
    const float tLowOverlap = fmin(tLow, tOverlap);
#define NODE_LOW(n) ((as_uint(M->bvhNodes[2 * (n) + 1].w) & VOLCL_MESH_BVH_OVERLAP) ? tLowOverlap : tLow)
#define NODE_COUNT(w) (as_uint(w) & ~VOLCL_MESH_BVH_OVERLAP)
#else
#define NODE_LOW(n) tLow
#define NODE_COUNT(w) as_uint(w)
#endif
    const float3 inv = (float3)(1.0f) / d;
    uint stack[64];
    int top = 0;
    /* Front to back: at an inner node both children's slabs are tested and the nearer one is visited
       first, so the nearest entry is usually found early and the rest culled by best.t. */
    uint ni = 0;
    for (;;) {
        const float4 lo = M->bvhNodes[2 * ni], hi = M->bvhNodes[2 * ni + 1];
        const uint count = NODE_COUNT(hi.w);
        if (count == 0) {
            const uint c0 = ni + 1, c1 = as_uint(lo.w);
            const float2 s0 = slab(M, c0, o, inv, NODE_LOW(c0), best.t),
                         s1 = slab(M, c1, o, inv, NODE_LOW(c1), best.t);
            const bool h0 = s0.x <= s0.y, h1 = s1.x <= s1.y;
            if (h0 && h1) {
                const bool near0 = s0.x <= s1.x;
                if (top < 64) stack[top++] = near0 ? c1 : c0;
                ni = near0 ? c0 : c1;
                continue;
            }
            if (h0 || h1) {
                ni = h0 ? c0 : c1;
                continue;
            }
        } else {
            leaf_faces(M, as_uint(lo.w), count, o, d, tMin, tExitMin, tOverlap, recent, &best);
        }
        /* Next pending node still in front of the best hit. */
        bool found = false;
        while (top > 0 && !found) {
            ni = stack[--top];
            const float2 sn = slab(M, ni, o, inv, NODE_LOW(ni), best.t);
            found = sn.x <= sn.y;
        }
        if (!found) break;
    }
#undef NODE_LOW
#undef NODE_COUNT
    return best;
}

/* Per-ray compositing state. */
typedef struct {
    float3 rgb;
    float alpha;
    float depth; /* world distance to the first iso-surface */
    float mip;
    float xray; /* optical depth */
    int inside;
    float nextSample; /* point sampling: normalised t of the next sample */
    /* MERGE_SEGMENTS: the pending run of segments, s from pendA to pendB over world length pendLen (0: none),
       ending at normalised t pendEnd; slopes ds/dlength of the run that keep its joints within tolerance. */
    float pendA, pendB, pendLen, pendEnd, slopeLo, slopeHi;
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

#if MODE == 4
/* Integral of c tau over a segment of world length len with s linear from sa to sb (emission only): c and tau
   are linear in s between knots, so their product is quadratic there and Simpson's rule on each piece between
   knots is exact. */
inline float3 segment_emission(const MeshData* M, const VolclTfParams* T, float sa, float sb, float len) {
    const float lo = fmin(sa, sb), hi = fmax(sa, sb);
    if (!(hi > lo)) {
        const float4 e = tf_sample(M->knots, T->knotCount, sa);
        return e.xyz * (e.w * len);
    }
    float3 sum = (float3)(0.0f);
    float s0 = lo;
    for (uint k = 0; k <= T->knotCount && s0 < hi; ++k) {
        const float s1 = k < T->knotCount ? fmin(M->knots[k].s, hi) : hi;
        if (!(s1 > s0)) continue;
        const float4 e0 = tf_sample(M->knots, T->knotCount, s0);
        const float4 em = tf_sample(M->knots, T->knotCount, 0.5f * (s0 + s1));
        const float4 e1 = tf_sample(M->knots, T->knotCount, s1);
        sum += (s1 - s0) * (e0.xyz * e0.w + 4.0f * em.xyz * em.w + e1.xyz * e1.w);
        s0 = s1;
    }
    return sum * (len / (6.0f * (hi - lo)));
}
#endif

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

/* The gradient shading takes at normalised x in tet `tet` whose constant gradient is g. */
inline float3 shade_gradient(const MeshData* M, uint tet, float3 g, float3 x) {
#ifdef SMOOTH_NORMALS
    __global const float4* n = M->normals + 3 * (size_t)tet;
    (void)g;
    return (float3)(dot(n[0].xyz, x) + n[0].w, dot(n[1].xyz, x) + n[1].w, dot(n[2].xyz, x) + n[2].w);
#else
    (void)M;
    (void)tet;
    (void)x;
    return g;
#endif
}

inline void composite(RayState* st, float3 rgb, float a) {
    const float w = 1.0f - st->alpha;
    st->rgb += w * rgb;
    st->alpha += w * a;
}

/* Composites the pending run of merged segments, if any. */
inline void flush_pending(const MeshData* M, const VolclTfParams* T, RayState* st) {
#ifdef MERGE_SEGMENTS
    if (st->pendLen > 0.0f) {
        const float4 e = preint_segment(M->table, T, st->pendA, st->pendB, st->pendLen);
        composite(st, e.xyz, e.w);
        st->pendLen = 0.0f;
    }
#endif
}

/* DVR over the normalised ray interval [ta, tb] of one tet with s from sa to sb. */
inline void dvr_piece(const MeshData* M, const VolclMeshRenderParams* Pc, const VolclTfParams* T,
                      const VolclLightingParams* Lp, const VolclCameraParams* C, float3 eye, float3 o,
                      float3 d, float ta, float tb, float sa, float sb, uint tet, float3 g, RayState* st) {
    if (!(tb > ta)) return;
    const float scale = Pc->mesh.scale;
#if PREINT == 3
    const float len = (tb - ta) * scale;
#ifdef MERGE_SEGMENTS
    /* Fine cells give many segments far shorter than a table slice, each a full lookup. Consecutive ones are
       looked up as one run while the scalar at every joint of the run stays within MERGE_TOL table node
       spacings of the straight line from the run's start to its end (the slopes that allow it narrow to a
       cone, updated per joint), so the table sees the exact run's (s_front, s_back, length) up to that
       tolerance. Runs stay within the table's longest length, so they need no splitting. */
    const float mergeLen = T->tableMaxLength;
    if (st->pendLen > 0.0f) {
        const float total = st->pendLen + len;
        const float tol = MERGE_TOL * (T->domainHi - T->domainLo) / (float)(T->tableSize - 1);
        const float lo = fmax(st->slopeLo, (st->pendB - tol - st->pendA) / st->pendLen);
        const float hi = fmin(st->slopeHi, (st->pendB + tol - st->pendA) / st->pendLen);
        const float m = (sb - st->pendA) / total;
        if (ta == st->pendEnd && total <= mergeLen && m >= lo && m <= hi) {
            st->pendB = sb;
            st->pendLen = total;
            st->pendEnd = tb;
            st->slopeLo = lo;
            st->slopeHi = hi;
            return;
        }
        flush_pending(M, T, st);
    }
    if (len > 0.0f && len <= mergeLen) {
        st->pendA = sa;
        st->pendB = sb;
        st->pendLen = len;
        st->pendEnd = tb;
        st->slopeLo = -INFINITY;
        st->slopeHi = INFINITY;
        return;
    }
#endif
    const float maxLen = Pc->mesh.maxSegment;
    const int n = len > maxLen ? (int)ceil(len / maxLen) : 1;
    const float sub = len / (float)n;
    float3 K = (float3)(1.0f), S = (float3)(0.0f);
#ifdef SHADING
    const float3 xm = o + (0.5f * (ta + tb)) * d;
    light_affine(Lp, C, eye, d, xm, shade_gradient(M, tet, g, xm), &K, &S);
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
            light_affine(Lp, C, eye, d, o + ts * d, shade_gradient(M, tet, g, o + ts * d), &K, &S);
#endif
            composite(st, (K * v.xyz + S) * a, a);
        }
    }
    st->nextSample = ts;
#endif
}

#ifdef NAN_COLOR
/* DVR over [ta, tb] (normalised) of a NaN cell (a tet with a non-finite vertex value): the NaN colour,
   unlit, as one exact constant segment (PREINT 3) or a sample of it at each lattice point. */
inline void nan_piece(const MeshData* M, const VolclMeshRenderParams* Pc, const VolclTfParams* T, float ta,
                      float tb, RayState* st) {
    if (!(tb > ta)) return;
    const float3 c = (float3)(NAN_R, NAN_G, NAN_B);
#if PREINT == 3
    flush_pending(M, T, st); /* keeps the order of the segments */
    const float a = 1.0f - exp(-NAN_TAU * (tb - ta) * Pc->mesh.scale);
    composite(st, c * a, a);
#else
    const float h = Pc->march.step * Pc->mesh.invScale;
    const float a = 1.0f - exp(-NAN_TAU * Pc->march.step);
    float ts = st->nextSample;
    if (ts < ta) ts += ceil((ta - ts) / h) * h;
    for (; ts < tb; ts += h)
        if (a > 0.0f) composite(st, c * a, a);
    st->nextSample = ts;
#endif
}
#endif

/* The part [ta, tb] (normalised) of the ray inside tet `tet`. */
inline void cell_segment(const MeshData* M, const VolclMeshRenderParams* Pc, const VolclTfParams* T,
                         const VolclLightingParams* Lp, const VolclCameraParams* C, float3 eye, float3 o,
                         float3 d, float tOffset, uint tet, float ta, float tb, float2 clip, RayState* st) {
    const float a = fmax(ta, clip.x), b = fmin(tb, clip.y);
    if (!(b >= a)) return;
#if defined(SKIPPING) && (MODE == 0 || MODE == 2)
    if (M->empty[tet]) return; /* point sampling: dvr_piece moves the lattice on to the next tet */
#endif
    const float4 f = M->cells[CELL_STRIDE * tet + 4];
#ifdef NAN_COLOR
    if (isnan(f.w)) { /* a NaN cell: the NaN colour in dvr; mip, xray and iso-surfaces ignore it */
#if MODE == 0
        nan_piece(M, Pc, T, a, b, st);
#endif
        return;
    }
#endif
    const float sa = dot(f.xyz, o + a * d) + f.w, sb = dot(f.xyz, o + b * d) + f.w;
#if MODE == 1
    st->mip = fmax(st->mip, fmax(sa, sb));
    st->inside = 1;
#elif MODE == 3
    if (b > a) st->xray += segment_depth(M, T, sa, sb, (b - a) * Pc->mesh.scale);
#elif MODE == 4
    if (b > a) st->rgb += segment_emission(M, T, sa, sb, (b - a) * Pc->mesh.scale);
#else
    if (!(b > a)) return;
    float u0 = 0.0f;
#if ISO_COUNT > 0
    /* Crossings inside the segment, in ray order. */
    float us[ISO_COUNT];
    int ids[ISO_COUNT];
    const int nc = iso_crossings(&Pc->iso, sa, sb, us, ids);
    for (int c = 0; c < nc; ++c) {
        const float u = us[c];
#if MODE == 0
        dvr_piece(M, Pc, T, Lp, C, eye, o, d, a + (b - a) * u0, a + (b - a) * u, sa + (sb - sa) * u0,
                  sa + (sb - sa) * u, tet, f.xyz, st);
#endif
        u0 = u;
        const int i = ids[c];
        const float t = a + (b - a) * u;
        float3 K, S;
        light_affine(Lp, C, eye, d, o + t * d, shade_gradient(M, tet, f.xyz, o + t * d), &K, &S);
        const float3 ic = (float3)(Pc->iso.color[i][0], Pc->iso.color[i][1], Pc->iso.color[i][2]);
        const float ia = Pc->iso.color[i][3];
        if (isinf(st->depth)) st->depth = (tOffset + t) * Pc->mesh.scale;
        composite(st, (K * ic + S) * ia, ia);
    }
#endif
#if MODE == 0
    dvr_piece(M, Pc, T, Lp, C, eye, o, d, a + (b - a) * u0, b, sa + (sb - sa) * u0, sb, tet, f.xyz, st);
#endif
#endif
}

/* Asks for tet's record ahead of its step: the rays of a work-item take turns, so it arrives while the others
   step (a chain of dependent loads otherwise). clang's builtin is used where the compiler targets a machine
   (PoCL: x86-64); elsewhere nothing is asked (a prefetch is only a hint). Not for SPIR targets: Oclgrind, which
   interprets SPIR, has neither llvm.prefetch (the builtin's lowering) nor OpenCL's prefetch(), and a program
   calling either has no kernels there (clCreateKernel: CL_INVALID_KERNEL_NAME). */
#if defined(__has_builtin) && !defined(__SPIR__)
#if __has_builtin(__builtin_prefetch)
#define CELL_PREFETCH_BUILTIN
#endif
#endif
inline void cell_prefetch(const MeshData* M, uint tet) {
#ifdef CELL_PREFETCH_BUILTIN
    __global const float4* c = M->cells + CELL_STRIDE * (size_t)tet;
    __builtin_prefetch(c);
    __builtin_prefetch(c + 4);
#else
    (void)M;
    (void)tet;
#endif
}

/* One ray's walk: where it is and what it has gathered. */
typedef struct {
    float3 o, d;
    float2 clip;
    float tOffset, t, tMin;
    float covered; /* MESH_OVERLAPS: the end of the part of the ray integrated so far */
    uint tet, entered, steps;
    int mayBeInside; /* the next search may start inside the mesh: it also looks for faces the ray leaves by */
    uint recent[RECENT];
    int ri, entries, phase; /* phase: 0 find the next entry, 1 walk, 2 done */
    RayState st;
} RayWalk;

#define PHASE_ENTRY 0
#define PHASE_WALK 1
#define PHASE_DONE 2

/* The pixel's ray in the normalised frame, its origin moved to where it meets the mesh box. */
inline void ray_begin(RayWalk* w, const VolclMeshRenderParams* Pc, uint x, uint y) {
    const VolclCameraParams* C = &Pc->camera;
    const VolclMeshParams* P = &Pc->mesh;
    w->st.rgb = (float3)(0.0f);
    w->st.alpha = 0.0f;
    w->st.depth = INFINITY;
    w->st.mip = -INFINITY;
    w->st.xray = 0.0f;
    w->st.inside = 0;
    w->st.nextSample = NAN; /* set at the first entry */
    w->st.pendLen = 0.0f;
    w->st.pendA = w->st.pendB = w->st.pendEnd = 0.0f;
    w->st.slopeLo = -INFINITY;
    w->st.slopeHi = INFINITY;
    w->phase = PHASE_DONE;
    w->steps = 0;
    w->entries = 0;
    w->ri = 0;
    w->tMin = 0.0f;
    for (int r = 0; r < RECENT; ++r)
        w->recent[r] = NO_FACE;
    if (x >= C->width || y >= C->height) return;
    const WorldRay wr = camera_ray_world(C, x, y);
    float3 o = (wr.o - v3(P->centre)) * P->invScale;
    const float3 d = wr.d;
    const float3 inv = (float3)(1.0f) / d;
    const float3 u = (v3(P->boxLo) - o) * inv, v = (v3(P->boxHi) - o) * inv;
    const float3 mn = fmin(u, v), mx = fmax(u, v);
    const float tBoxLine = fmax(fmax(mn.x, mn.y), mn.z);
    const float tBox0 = fmax(tBoxLine, 0.0f);
    const float tBox1 = fmin(fmin(mx.x, mx.y), mx.z);
    if (!(tBox1 >= tBox0)) return;
    /* Relative parameters near the mesh keep float precision for far cameras. */
    w->tOffset = fmax(tBox0 - 1e-3f, 0.0f);
    o += w->tOffset * d;
    w->o = o;
    w->d = d;
    /* From outside the mesh's box the first boundary face met is an entering one. */
    w->mayBeInside = w->tOffset == 0.0f;
    w->clip = (float2)(-INFINITY, INFINITY);
#ifdef CLIPPING
    clip_planes(&Pc->clip, o, d, &w->clip);
#endif
#ifdef MESH_OVERLAPS
    /* Entries are taken along the whole line through the mesh box, behind the eye too (a walk from there covers
       an eye inside the mesh); only t >= 0 counts. */
    w->tMin = fmin(tBoxLine - w->tOffset - 1e-3f, 0.0f);
    w->covered = w->tMin;
    w->clip.x = fmax(w->clip.x, 0.0f);
#endif
    if (w->clip.y > w->clip.x) w->phase = PHASE_ENTRY;
}

/* A ray inside the mesh at tMin (hit.face, which it leaves by at tExit, is the first boundary face ahead): walks
   back against d through face-adjacent tets to the tet holding the point at tMin and starts there with no
   entry face (entered 4); if the walk back leaves the mesh after tMin, the ray enters there instead. */
inline void locate_back(const MeshData* M, RayWalk* w, uint face, float tExit) {
    uint tet = face >> 2, came = face & 3u;
    float t = tExit;
    for (; w->steps < MAX_STEPS; ++w->steps) {
        __global const float4* cell = M->cells + CELL_STRIDE * (size_t)tet;
        float back = -INFINITY;
        uint backFace = 4;
        for (uint fi = 0; fi < 4; ++fi) {
            if (fi == came) continue;
            const float4 pl = cell[fi];
            const float nd = dot(pl.xyz, w->d);
            if (!(nd < 0.0f)) continue;
            const float tf = fmin(-(dot(pl.xyz, w->o) + pl.w) / nd, t);
            if (tf > back) {
                back = tf;
                backFace = fi;
            }
        }
        if (backFace == 4 || back <= w->tMin) break;
        const uint nb = ((__global const uint*)(cell + 5))[backFace];
        if (nb >= VOLCL_MESH_HULL_FACE) {
            w->tet = tet;
            w->entered = backFace;
            w->t = back;
            return;
        }
        tet = nb >> 2;
        came = nb & 3u;
        t = back;
    }
    w->tet = tet;
    w->entered = 4;
    w->t = w->tMin;
}

/* One unit of work of a ray: find its next entry into the mesh, or cross one tet.
   MESH_OVERLAPS: the part of the ray inside the mesh is the union of its intervals in the tets, and a walk from
   an entering boundary face through face-adjacent tets up to the boundary face it leaves by is one interval of
   the union. The ray takes every entering face along the line in the order of t (tMin is the last one), walks
   from each, and integrates only past `covered`, the end of what earlier walks covered: intervals taken in
   the order of their start add up to their union, however many layers of folded tets or components overlap.
   [tMin, covered] is covered by the walks so far, so an entering face there belongs to a tet that overlaps
   another: only the faces of such tets (marked on the host) are searched before `covered`. */
inline void ray_advance(RayWalk* w, const MeshData* M, const VolclMeshRenderParams* Pc,
                        const VolclTfParams* T, const VolclLightingParams* Lp, float3 eye, uint* seed) {
    const VolclMeshParams* P = &Pc->mesh;
    if (w->phase == PHASE_ENTRY) {
#ifdef MESH_OVERLAPS
        const Entry hit = first_entry(M, P, w->o, w->d, w->covered - P->epsilon, INFINITY,
                                      w->tMin - P->epsilon, w->recent, *seed);
#else
        const Entry hit =
            first_entry(M, P, w->o, w->d, w->tMin - P->epsilon,
                        w->mayBeInside ? w->tMin + P->epsilon : INFINITY, w->tMin, w->recent, *seed);
#endif
        if (hit.face == NO_FACE || hit.t > w->clip.y || ++w->entries > MAX_ENTRIES) {
            w->phase = PHASE_DONE;
            return;
        }
        *seed = hit.leaf;
        if (hit.entering) {
            w->recent[w->ri] = hit.face;
            w->ri = (w->ri + 1) % RECENT;
            w->tet = hit.face >> 2;
            w->entered = hit.face & 3u;
            w->t = hit.t;
#ifdef MESH_OVERLAPS
            w->tMin = hit.t;
#endif
        } else {
            locate_back(M, w, hit.face, hit.t);
        }
        /* The point-sampling lattice starts half a step into the mesh. */
        if (isnan(w->st.nextSample))
            w->st.nextSample = fmax(w->t, w->clip.x) + 0.5f * Pc->march.step * P->invScale;
        w->phase = PHASE_WALK;
        return;
    }
    const uint tet = w->tet;
    __global const float4* cell = M->cells + CELL_STRIDE * (size_t)tet;
    /* The nearest plane ahead: t_f = num_f / nd_f with nd_f > 0, compared as num_a nd_b < num_b nd_a so that
       only the chosen face is divided. */
    float bestNum = INFINITY, bestNd = 1.0f, steepestNd = -INFINITY;
    uint exitFace = 4, steepest = 0;
    for (uint fi = 0; fi < 4; ++fi) {
        if (fi == w->entered) continue;
        const float4 pl = cell[fi];
        const float nd = dot(pl.xyz, w->d);
        if (nd > steepestNd) {
            steepestNd = nd;
            steepest = fi;
        }
        if (!(nd > 0.0f)) continue;
        const float num = -(dot(pl.xyz, w->o) + pl.w);
        if (exitFace == 4 || num * bestNd < bestNum * nd) {
            bestNum = num;
            bestNd = nd;
            exitFace = fi;
        }
    }
    float best = bestNum / bestNd;
    if (exitFace == 4) { /* no face ahead (a ray in the plane of a flat tet): leave at once */
        exitFace = steepest;
        best = w->t;
    }
    const float tExit = fmax(best, w->t);
#ifdef MESH_OVERLAPS
    const float tFrom = fmax(w->t, w->covered);
    if (tExit >= tFrom)
        cell_segment(M, Pc, T, Lp, &Pc->camera, eye, w->o, w->d, w->tOffset, tet, tFrom, tExit, w->clip,
                     &w->st);
    w->covered = fmax(w->covered, tExit);
#else
    cell_segment(M, Pc, T, Lp, &Pc->camera, eye, w->o, w->d, w->tOffset, tet, w->t, tExit, w->clip, &w->st);
#endif
    w->t = tExit;
#if defined(EARLY_TERMINATION) && (MODE == 0 || MODE == 2)
    if (w->st.alpha >= Pc->march.earlyTermination) {
        w->phase = PHASE_DONE;
        return;
    }
#endif
    if (w->t > w->clip.y || ++w->steps >= MAX_STEPS) {
        w->phase = PHASE_DONE;
        return;
    }
    const uint nb = ((__global const uint*)(cell + 5))[exitFace];
    if (nb >=
        VOLCL_MESH_HULL_FACE) { /* left the mesh: for good through a hull face, else look for a re-entry */
#ifndef MESH_OVERLAPS
        w->tMin = w->t; /* without overlaps the ray is outside here: the next entry lies ahead */
#endif
        w->phase = nb == VOLCL_MESH_HULL_FACE ? PHASE_DONE : PHASE_ENTRY;
        return;
    }
    w->tet = nb >> 2;
    w->entered = nb & 3u;
    cell_prefetch(M, w->tet);
}

/* The pixel's colour from its ray's state. */
inline float4 ray_result(const RayWalk* w, const MeshData* M, const VolclMeshRenderParams* Pc) {
    const RayState* st = &w->st;
#if MODE == 1
    if (!st->inside) return (float4)(0.0f);
    const float m = st->mip;
#if MIP_COLOR == 2
    const float4 tv = tf_sample(M->knots, Pc->tf.knotCount, m);
    const float a = 1.0f - exp(-tv.w);
    return (float4)(tv.xyz * a, a);
#else
    const float g = clamp((m - Pc->march.windowLo) * Pc->march.windowInvWidth, 0.0f, 1.0f);
#if MIP_COLOR == 1
    const float4 tv = tf_sample(M->knots, Pc->tf.knotCount, m);
    return (float4)(tv.xyz * g, g);
#else
    return (float4)(g, g, g, g);
#endif
#endif
#elif MODE == 3
    const float a = -expm1(-st->xray);
    return (float4)(a, a, a, a);
#elif MODE == 4
    return (float4)(st->rgb, 0.0f);
#else
    return (float4)(st->rgb, st->alpha);
#endif
}

/* Each work-item walks the rays of a RAYS_X x RAYS_Y pixel block together, one tet (or one entry search) per
   ray in turn: the walk is a chain of dependent loads, and interleaving independent rays lets the CPU (or a
   GPU's scheduler) overlap their memory latency. */
#ifndef RAYS_X /* set by the host (DeviceProfile::Mesh::cellRaysX, cellRaysY) */
#define RAYS_X 2
#define RAYS_Y 2
#endif
#define RAYS (RAYS_X * RAYS_Y)

__kernel void mesh_cells(__global const float4* cells, __global const uchar* empty,
                         __global const float4* bvhNodes, __global const float4* bvhFaces,
                         __global const VolclTfKnot* knots, __global const float* tauIntegral,
                         __global const float4* table, __global const float4* normals,
                         const VolclMeshRenderParams params, __global float4* out, __global float* depthOut) {
    const VolclMeshRenderParams* Pc = &params;
    const uint x0 = get_global_id(0) * RAYS_X, y0 = get_global_id(1) * RAYS_Y;
    const VolclCameraParams C = Pc->camera;
    if (x0 >= C.width || y0 >= C.height) return;
    MeshData M = {cells, empty, bvhNodes, bvhFaces, knots, tauIntegral, table, normals};
    const VolclTfParams T = Pc->tf;
    const VolclLightingParams Lp = Pc->lighting;
    const float3 eye = (v3(C.origin) - v3(Pc->mesh.centre)) * Pc->mesh.invScale;
    RayWalk w[RAYS];
    uint seed = NO_FACE; /* the face the block's last entry search found */
    for (int r = 0; r < RAYS; ++r)
        ray_begin(&w[r], Pc, x0 + r % RAYS_X, y0 + r / RAYS_X);
    for (;;) {
        bool active = false;
        for (int r = 0; r < RAYS; ++r) {
            if (w[r].phase == PHASE_DONE) continue;
            active = true;
            ray_advance(&w[r], &M, Pc, &T, &Lp, eye, &seed);
        }
        if (!active) break;
    }
    for (int r = 0; r < RAYS; ++r) {
        const uint x = x0 + r % RAYS_X, y = y0 + r / RAYS_X;
        if (x >= C.width || y >= C.height) continue;
        flush_pending(&M, &T, &w[r].st);
        const size_t pixel = (size_t)y * C.width + x;
        out[pixel] = ray_result(&w[r], &M, Pc);
        depthOut[pixel] = w[r].st.depth;
    }
}
