/* Fog for the ray marchers: closed-form optical depth of the height fog along a ray, and its exact
   compositing with a volume segment of constant extinction (render/FogModel.hpp states the model). */
#ifndef VOLCL_FOG_H
#define VOLCL_FOG_H

#include "camera_rays.h"

#pragma OPENCL FP_CONTRACT OFF

/* The fog along one world ray o + t d: height h(t) = h0 + b t along up, and the ray's interval in the box. */
typedef struct {
    float h0, b;
    float2 span; /* span.y <= span.x: the ray misses the fog box */
} FogRay;

inline FogRay fog_ray(const VolclFogParams* F, float3 o, float3 d) {
    FogRay f;
    const float3 up = v3(F->up);
    f.h0 = dot(o, up);
    f.b = dot(d, up);
    float t0 = 0.0f, t1 = INFINITY;
    const float oa[3] = {o.x, o.y, o.z}, da[3] = {d.x, d.y, d.z};
    for (int a = 0; a < 3; ++a) {
        if (da[a] == 0.0f) {
            if (oa[a] < F->lo[a] || oa[a] > F->hi[a]) t1 = -INFINITY;
        } else {
            const float u = (F->lo[a] - oa[a]) / da[a], v = (F->hi[a] - oa[a]) / da[a];
            t0 = fmax(t0, fmin(u, v));
            t1 = fmin(t1, fmax(u, v));
        }
    }
    f.span = (float2)(t0, t1);
    return f;
}

/* (1 - exp(-y)) / y for y >= 0, without cancellation near 0. */
inline float fog_phi(float y) {
    return y < 1e-4f ? 1.0f - 0.5f * y : -expm1(-y) / y;
}

/* Fog extinction at ray parameter t for the base `base`. */
inline float fog_sigma(const VolclFogParams* F, const FogRay* f, float base, float t) {
    const float dh = f->h0 + f->b * t - base;
    if (dh <= 0.0f) return F->color[3];
    const float invH = F->lo[3];
    return invH < 0.0f ? 0.0f : F->color[3] * exp(-dh * invH);
}

/* Optical depth of the fog over [u, v] on one side of the base (the whole piece below or above it):
   below, density * length; above, the exponential's exact integral taken from the piece's lower end, so
   every exponent is <= 0 (rays parallel to the layers, falloff -> 0 and -> infinity stay finite). */
inline float fog_depth_piece(const VolclFogParams* F, const FogRay* f, float base, float u, float v,
                             bool above) {
    const float len = v - u;
    if (!(len > 0.0f)) return 0.0f;
    const float rho = F->color[3];
    if (!above) return rho * len;
    const float invH = F->lo[3];
    if (invH < 0.0f) return 0.0f;
    const float hl = fmin(f->h0 + f->b * u, f->h0 + f->b * v) - base;
    return rho * exp(-fmax(hl, 0.0f) * invH) * len * fog_phi(fabs(f->b) * invH * len);
}

/* (1 - exp(-z)) / z for z of either sign (|z| <= ~1 where it is used). */
inline float fog_phis(float z) {
    return fabs(z) < 1e-4f ? 1.0f - 0.5f * z : -expm1(-z) / z;
}

/* Fog depth over [x, x + d] above the base from sigma(x) = sx (fast form), or the stable lower-end form
   where the fog grows more than e-fold along it (then sx may have underflowed). */
inline float fog_sub_depth(const VolclFogParams* F, const FogRay* f, float base, float sx, float ks, float x,
                           float d) {
    const float z = ks * d;
    return z > -1.0f ? sx * d * fog_phis(z) : fog_depth_piece(F, f, base, x, x + d, true);
}

/* Accumulates one piece [u, v] (one side of the base, constant base) with volume extinction a:
   *depth += optical depth of volume + fog, *J += exp(-*depth before) * integral of exp(-depth inside). */
inline void fog_piece(const VolclFogParams* F, const FogRay* f, float base, float u, float v, float a,
                      float* depth, float* J) {
    const float len = v - u;
    if (!(len > 0.0f)) return;
    const bool above = f->h0 + f->b * (0.5f * (u + v)) > base;
    const float D = fog_depth_piece(F, f, base, u, v, above);
    const float kappa = above && F->lo[3] > 0.0f ? fabs(f->b) * F->lo[3] : 0.0f;
    if (a > 0.0f) {
        const float Tin = *depth > 0.0f ? exp(-*depth) : 1.0f;
        if (D == 0.0f || kappa * len < 1e-6f) {
            /* Constant total extinction over the piece: closed form. */
            const float s = a + D / len;
            *J += Tin * len * fog_phi(s * len);
        } else {
            /* Exponential fog with a constant volume: sub-intervals with optical depth and fog variation
               each at most 0.5, three-point Gauss-Legendre on exp(-depth) (error ~1e-8 relative). Inside
               a sub-interval starting at x the fog is sigma(x) exp(-ks (t - x)), ks = dh/dt / falloff. */
            const float Phi = a * len + D;
            const int m = (int)clamp(ceil(fmax(Phi, kappa * len) * 2.0f), 1.0f, 64.0f);
            const float dlt = len / (float)m;
            const float ks = f->b * F->lo[3];
            const float g0 = 0.5f - 0.5f * 0.7745966692f, g2 = 0.5f + 0.5f * 0.7745966692f;
            float inner = 0.0f;
            for (int i = 0; i < m; ++i) {
                const float x = u + (float)i * dlt, y = i == m - 1 ? v : x + dlt;
                const float w = y - x;
                const float Ti = inner > 0.0f ? Tin * exp(-inner) : Tin;
                if (Ti < 1e-9f) break;
                const float sx = fog_sigma(F, f, base, x);
                const float di = m == 1 ? Phi : a * w + fog_depth_piece(F, f, base, x, y, true);
                float Ji;
                if (di > 1.0f) {
                    /* Opaque within the sub-interval: the light comes from its front. */
                    Ji = -expm1(-di) / (a + sx);
                } else {
                    const float da = g0 * w, db = 0.5f * w, dc = g2 * w;
                    Ji = w * ((5.0f / 18.0f) * exp(-(a * da + fog_sub_depth(F, f, base, sx, ks, x, da))) +
                              (8.0f / 18.0f) * exp(-(a * db + fog_sub_depth(F, f, base, sx, ks, x, db))) +
                              (5.0f / 18.0f) * exp(-(a * dc + fog_sub_depth(F, f, base, sx, ks, x, dc))));
                }
                *J += Ti * Ji;
                inner += di;
            }
        }
    }
    *depth += a * len + D;
}

/* A piece [u, v] with no fog: the volume alone. */
inline void fog_clear_piece(float u, float v, float a, float* depth, float* J) {
    const float len = v - u;
    if (!(len > 0.0f)) return;
    if (a > 0.0f) *J += exp(-*depth) * len * fog_phi(a * len);
    *depth += a * len;
}

/* One stretch [u, v] of constant base: split at the fog box and at the base crossing. */
inline void fog_stretch(const VolclFogParams* F, const FogRay* f, float base, float u, float v, float a,
                        float* depth, float* J) {
    const float fu = clamp(u, f->span.x, f->span.y), fv = clamp(v, f->span.x, f->span.y);
    if (!(f->span.y > f->span.x) || !(fv > fu)) {
        fog_clear_piece(u, v, a, depth, J);
        return;
    }
    fog_clear_piece(u, fu, a, depth, J);
    const float tc = f->b != 0.0f ? (base - f->h0) / f->b : INFINITY;
    if (tc > fu && tc < fv) {
        fog_piece(F, f, base, fu, tc, a, depth, J);
        fog_piece(F, f, base, tc, fv, a, depth, J);
    } else {
        fog_piece(F, f, base, fu, fv, a, depth, J);
    }
    fog_clear_piece(fv, v, a, depth, J);
}

/* The interval [u, v] of a ray with constant volume extinction a (0: fog alone): its total optical depth and
   the volume's share of its opacity, aJ = a * integral exp(-depth); the fog's share is opacity - aJ (exact:
   emission of a medium pair splits by parts into these two terms). FOG_MAP: the base per map texel. */
inline void fog_interval(const VolclFogParams* F, __global const float* fogMap, const FogRay* f, float3 o,
                         float3 d, float u, float v, float a, float* depth, float* aJ) {
    float dep = 0.0f, J = 0.0f;
#ifdef FOG_MAP
    /* Walk the map's texels (nearest texel: constant base per texel) along [u, v]. */
    const uint A0 = F->mapAxis[0], A1 = F->mapAxis[1];
    const float oa[3] = {o.x, o.y, o.z}, da[3] = {d.x, d.y, d.z};
    const float c0 = (F->hi[A0] - F->lo[A0]) / (float)F->mapSize[0],
                c1 = (F->hi[A1] - F->lo[A1]) / (float)F->mapSize[1];
    float t = u;
    int guard = 0;
    while (t < v && guard++ < 65536) {
        const float tm = t; /* texel at t, nudged along the ray by choosing the side the ray moves to */
        const float p0 = (oa[A0] + da[A0] * tm - F->lo[A0]) / c0,
                    p1 = (oa[A1] + da[A1] * tm - F->lo[A1]) / c1;
        int i = (int)floor(p0), j = (int)floor(p1);
        if (da[A0] < 0.0f && p0 == floor(p0)) --i;
        if (da[A1] < 0.0f && p1 == floor(p1)) --j;
        i = clamp(i, 0, (int)F->mapSize[0] - 1);
        j = clamp(j, 0, (int)F->mapSize[1] - 1);
        float tn = v;
        if (da[A0] > 0.0f && i < (int)F->mapSize[0] - 1)
            tn = fmin(tn, (F->lo[A0] + (float)(i + 1) * c0 - oa[A0]) / da[A0]);
        if (da[A0] < 0.0f && i > 0) tn = fmin(tn, (F->lo[A0] + (float)i * c0 - oa[A0]) / da[A0]);
        if (da[A1] > 0.0f && j < (int)F->mapSize[1] - 1)
            tn = fmin(tn, (F->lo[A1] + (float)(j + 1) * c1 - oa[A1]) / da[A1]);
        if (da[A1] < 0.0f && j > 0) tn = fmin(tn, (F->lo[A1] + (float)j * c1 - oa[A1]) / da[A1]);
        if (!(tn > t)) tn = fmin(nextafter(t, INFINITY), v);
        fog_stretch(F, f, fogMap[(size_t)j * F->mapSize[0] + (size_t)i], t, tn, a, &dep, &J);
        t = tn;
    }
#else
    (void)fogMap;
    (void)o;
    (void)d;
    fog_stretch(F, f, F->up[3], u, v, a, &dep, &J);
#endif
    *depth = dep;
    *aJ = a * J;
}

/* Composites the fog alone over [u, v] onto (rgb, T). */
inline void fog_only(const VolclFogParams* F, __global const float* fogMap, const FogRay* f, float3 o,
                     float3 d, float u, float v, float3* rgb, float* T) {
    if (!(v > u)) return;
    float depth, aJ;
    fog_interval(F, fogMap, f, o, d, u, v, 0.0f, &depth, &aJ);
    const float op = -expm1(-depth);
    *rgb += *T * op * v3(F->color);
    *T *= exp(-depth);
}

/* Composites a volume segment [u, v] of constant extinction a and straight colour c together with the fog
   over it. */
inline void fog_with_segment(const VolclFogParams* F, __global const float* fogMap, const FogRay* f, float3 o,
                             float3 d, float u, float v, float a, float3 c, float3* rgb, float* T) {
    float depth, aJ;
    fog_interval(F, fogMap, f, o, d, u, v, a, &depth, &aJ);
    const float op = -expm1(-depth);
    aJ = clamp(aJ, 0.0f, op);
    *rgb += *T * (aJ * c + (op - aJ) * v3(F->color));
    *T *= exp(-depth);
}

#endif
