/* Multiple scattering in the grid's heterogeneous medium: a Monte Carlo path tracer (delta tracking over a
   majorant grid, ratio-tracked shadow rays, Henyey-Greenstein phase, next-event estimation to the lights
   and the sky), seeded per pixel and sample, accumulated progressively. C++ reference:
   render/grid/PathTraceReference.cpp (same algorithm and random stream, in double). */
#include "common/camera_rays.h"
#include "common/counter_rng.h"
#include "common/grid_sample.h"
#include "common/shading.h"
#include "common/tf_lookup.h"

#pragma OPENCL FP_CONTRACT OFF

/* The medium: extinction sigma_t = tau(s) of the TF at the trilinear field, per-channel scattering albedo
   albedo * c(s), emission c(s) * tau(s) when P->emission is 1. */

inline float pt_uniform(VolclRng* r) {
    return (float)volcl_rng_next24(r) * (1.0f / 16777216.0f);
}

/* Macrocell holding voxel point o + tq * d, and the ray parameter where the ray leaves it (>= tq). */
inline uint pt_cell(const VolclGridParams* G, float3 o, float3 d, float tq, float* exitT) {
    const float3 p = o + tq * d;
    const float B = (float)G->macroDims[3];
    const int3 m = (int3)((int)G->macroDims[0] - 1, (int)G->macroDims[1] - 1, (int)G->macroDims[2] - 1);
    const int3 c = clamp(convert_int3(floor(p / B)), (int3)(0), m);
    const float3 lo = convert_float3(c) * B;
    const float3 hi = fmin(lo + B, grid_hi(G));
    const float pa[3] = {p.x, p.y, p.z}, da[3] = {d.x, d.y, d.z};
    const float la[3] = {lo.x, lo.y, lo.z}, ha[3] = {hi.x, hi.y, hi.z};
    float e = INFINITY;
    for (int a = 0; a < 3; ++a) {
        if (da[a] > 0.0f)
            e = fmin(e, (ha[a] - pa[a]) / da[a]);
        else if (da[a] < 0.0f)
            e = fmin(e, (la[a] - pa[a]) / da[a]);
    }
    *exitT = tq + fmax(e, 0.0f);
    return ((uint)c.z * G->macroDims[1] + (uint)c.y) * G->macroDims[0] + (uint)c.x;
}

/* A parameter step that moves the ray 1e-4 voxel: the cell of a point just past t is the one [t, exit] lies in. */
inline float pt_eps(float3 d) {
    return 1e-4f / fmax(fmax(fabs(d.x), fabs(d.y)), fabs(d.z));
}

/* Delta tracking on [t, tEnd]: the first real collision (its TF value in *e), or INFINITY when the ray
   leaves. Cells with majorant 0 are crossed without a sample. */
inline float pt_delta_track(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                            __global const float* majorant, const VolclGridRenderParams* P, float3 o,
                            float3 d, float t, float tEnd, VolclRng* rng, float4* e) {
    const float eps = pt_eps(d);
    while (t < tEnd) {
        float cellExit;
        const uint c = pt_cell(&P->grid, o, d, t + eps, &cellExit);
        const float segEnd = fmin(cellExit, tEnd);
        const float mu = majorant[c];
        if (mu > 0.0f) {
            for (;;) {
                t -= log(1.0f - pt_uniform(rng)) / mu;
                if (t >= segEnd) break;
                *e = tf_sample(knots, P->tf.knotCount, sample_volume(vol, &P->grid, o + t * d));
                if (pt_uniform(rng) * mu < e->w) return t;
            }
        }
        t = segEnd;
    }
    return INFINITY;
}

/* Ratio tracking on [t, tEnd]: an unbiased estimate of the transmittance (Russian roulette below 0.1). */
inline float pt_transmittance(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                              __global const float* majorant, const VolclGridRenderParams* P, float3 o,
                              float3 d, float t, float tEnd, VolclRng* rng) {
    const float eps = pt_eps(d);
    float T = 1.0f;
    while (t < tEnd) {
        float cellExit;
        const uint c = pt_cell(&P->grid, o, d, t + eps, &cellExit);
        const float segEnd = fmin(cellExit, tEnd);
        const float mu = majorant[c];
        if (mu > 0.0f) {
            for (;;) {
                t -= log(1.0f - pt_uniform(rng)) / mu;
                if (t >= segEnd) break;
                const float sigma =
                    tf_sample(knots, P->tf.knotCount, sample_volume(vol, &P->grid, o + t * d)).w;
                T *= fmax(1.0f - sigma / mu, 0.0f);
                if (T < 0.1f) {
                    if (pt_uniform(rng) >= 0.5f) return 0.0f;
                    T *= 2.0f;
                }
            }
        }
        t = segEnd;
    }
    return T;
}

inline float pt_phase(float g, float cosTheta) {
    const float denom = 1.0f + g * g - 2.0f * g * cosTheta;
    return (1.0f - g * g) / (4.0f * M_PI_F * denom * sqrt(denom));
}

/* A direction drawn from the Henyey-Greenstein phase around the unit direction `dir` (the path's own). */
inline float3 pt_sample_phase(float3 dir, float g, float u1, float u2) {
    float ct;
    if (fabs(g) < 1e-3f) {
        ct = 1.0f - 2.0f * u1;
    } else {
        const float sq = (1.0f - g * g) / (1.0f - g + 2.0f * g * u1);
        ct = (1.0f + g * g - sq * sq) / (2.0f * g);
    }
    ct = clamp(ct, -1.0f, 1.0f);
    const float st = sqrt(fmax(0.0f, 1.0f - ct * ct)), phi = 2.0f * M_PI_F * u2;
    /* Orthonormal basis around dir (Duff et al. 2017). */
    const float sgn = dir.z >= 0.0f ? 1.0f : -1.0f;
    const float a = -1.0f / (sgn + dir.z), b = dir.x * dir.y * a;
    const float3 t1 = (float3)(1.0f + sgn * dir.x * dir.x * a, sgn * b, -sgn * dir.x);
    const float3 t2 = (float3)(b, sgn + dir.y * dir.y * a, -dir.y);
    return normalize(st * cos(phi) * t1 + st * sin(phi) * t2 + ct * dir);
}

/* One path from the eye through pixel (x, y): (rgb radiance, 1 - transmittance of the primary ray). */
inline float4 pt_sample(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                        __global const float* majorant, const VolclGridRenderParams* P,
                        const VolclPathParams* Q, const Ray* r, float2 span, VolclRng* rng) {
    const float3 hi = grid_hi(&P->grid), inv = v3(P->grid.invSpacing), org = v3(P->grid.origin),
                 spc = v3(P->grid.spacing);
    const float3 env = v3(Q->environment);
    const bool sky = env.x > 0.0f || env.y > 0.0f || env.z > 0.0f;
    const float g = P->lighting.phaseG;
    const float Tp = pt_transmittance(vol, knots, majorant, P, r->o, r->d, span.x, span.y, rng);
    float3 L = (float3)(0.0f), beta = (float3)(1.0f);
    float3 o = r->o, d = r->d, dW = r->dWorld;
    float t0 = span.x, t1 = span.y;
    for (uint k = 1;; ++k) {
        float4 e;
        const float t = pt_delta_track(vol, knots, majorant, P, o, d, t0, t1, rng, &e);
        if (!(t < INFINITY)) break;
        const float3 pv = o + t * d, xw = org + pv * spc;
        const float3 c = e.xyz;
        if (Q->emission != 0.0f) L += beta * c;
        const float3 a = clamp(P->lighting.albedo * c, 0.0f, 1.0f);
        if (!(a.x > 0.0f || a.y > 0.0f || a.z > 0.0f)) break;
        /* Next-event estimation: each light, then the sky along a phase-sampled direction (weight 1). */
        for (uint i = 0; i < P->lighting.lightCount; ++i) {
            float dist;
            const float3 Ld =
                light_dir(&P->lighting, P->camera.perspective, r->oWorld, r->dWorld, (int)i, xw, &dist);
            const float3 dv = Ld * inv;
            const float2 s2 = clip_box(pv, dv, hi, 0.0f, dist);
            const float Tr =
                s2.y > s2.x ? pt_transmittance(vol, knots, majorant, P, pv, dv, s2.x, s2.y, rng) : 1.0f;
            L += beta * a * v3(P->lighting.lightColor[i]) * (pt_phase(g, dot(Ld, dW)) * Tr);
        }
        if (sky) {
            const float u1 = pt_uniform(rng), u2 = pt_uniform(rng);
            const float3 wv = pt_sample_phase(dW, g, u1, u2) * inv;
            const float2 s2 = clip_box(pv, wv, hi, 0.0f, INFINITY);
            const float Tr =
                s2.y > s2.x ? pt_transmittance(vol, knots, majorant, P, pv, wv, s2.x, s2.y, rng) : 1.0f;
            L += beta * a * env * Tr;
        }
        if (k >= Q->maxBounces) break;
        beta *= a;
        if (k >= 3) { /* Russian roulette on the throughput */
            const float q = fmin(fmax(fmax(beta.x, beta.y), beta.z), 1.0f);
            if (pt_uniform(rng) >= q) break;
            beta /= q;
        }
        const float u1 = pt_uniform(rng), u2 = pt_uniform(rng);
        dW = pt_sample_phase(dW, g, u1, u2);
        o = pv;
        d = dW * inv;
        const float2 s = clip_box(o, d, hi, 0.0f, INFINITY);
        t0 = s.x;
        t1 = s.y;
    }
    return (float4)(L, 1.0f - Tp);
}

/* Adds samples firstSample .. firstSample + sampleCount - 1 of every pixel to accum and writes the mean so
   far (accum * invTotal) to out. */
__kernel void pathtrace(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                        __global const float* majorant, const VolclGridRenderParams params,
                        const VolclPathParams path, __global float4* accum, __global float4* out) {
    const uint x = get_global_id(0), y = get_global_id(1);
    if (x >= params.camera.width || y >= params.camera.height) return;
    const VolclGridRenderParams* P = &params;
    const uint pix = y * params.camera.width + x;
    const Ray r = grid_ray(&P->grid, camera_ray_world(&P->camera, x, y));
    const float2 span = clip_box(r.o, r.d, grid_hi(&P->grid), 0.0f, INFINITY);
    float4 sum = path.firstSample == 0U ? (float4)(0.0f) : accum[pix];
    if (span.y > span.x) {
        for (uint s = 0; s < path.sampleCount; ++s) {
            VolclRng rng = volcl_rng_start(path.seed, pix, path.firstSample + s);
            sum += pt_sample(vol, knots, majorant, P, &path, &r, span, &rng);
        }
    }
    accum[pix] = sum;
    out[pix] = sum * path.invTotal;
}
