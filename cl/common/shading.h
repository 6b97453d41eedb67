/* Lighting for every renderer: light directions, Blinn-Phong from a gradient, single scattering with the
   Henyey-Greenstein phase, summed over the lights. The renderer supplies the gradient and each light's
   visibility (its own shadow rays); SHADING and SCATTERING select the terms at compile time. */
#ifndef VOLCL_SHADING_H
#define VOLCL_SHADING_H

#include "camera_rays.h"

#pragma OPENCL FP_CONTRACT OFF

/* Unit direction from world point x toward light i, and the distance to it (INFINITY for directional).
   eye and rayDir are the camera ray's world origin and unit direction (the head light sits at the eye of
   a perspective camera, and shines along the view in an orthographic one). */
inline float3 light_dir(const VolclLightingParams* Lp, uint perspective, float3 eye, float3 rayDir, int i,
                        float3 x, float* dist) {
    const float kind = Lp->lightPos[i][3];
    if (kind == VOLCL_LIGHT_POINT) {
        const float3 v = v3(Lp->lightPos[i]) - x;
        *dist = length(v);
        return *dist > 0.0f ? v / *dist : -rayDir;
    }
    if (kind == VOLCL_LIGHT_HEAD) {
        if (perspective) {
            const float3 v = eye - x;
            *dist = length(v);
            return *dist > 0.0f ? v / *dist : -rayDir;
        }
        *dist = INFINITY;
        return -rayDir;
    }
    *dist = INFINITY;
    return v3(Lp->lightPos[i]);
}

/* x^n for the specular term, x in [0, 1]. Integer exponents up to 1024 by repeated squaring (relative error
   below (n + 11) 2^-24: RenderCommon.SpecularPowerWithinItsStatedBound), others by exp2(n * log2(x)); pow()
   handles every sign and special case and cost a third of a shaded frame. */
inline float specular_power(float x, float n) {
    if (!(x > 0.0f)) return n == 0.0f ? 1.0f : 0.0f;
    if (n == floor(n) && n <= 1024.0f) {
        uint e = (uint)n;
        float r = 1.0f, b = x;
        while (e) {
            if (e & 1u) r *= b;
            b *= b;
            e >>= 1;
        }
        return r;
    }
    return exp2(n * log2(x));
}

/* The light gathered at one sample, light by light: light_begin, light_add per light, light_finish. */
typedef struct {
#ifdef SHADING
    float3 N, V, diffuse, specular;
    float gl;
#endif
#ifdef SCATTERING
    float3 scattered;
#endif
    int unused;
} LightSum;

/* g: the world-space gradient of the field at the sample (read only with SHADING); rayDir: unit view ray. */
inline LightSum light_begin(const VolclLightingParams* Lp, float3 g, float3 rayDir) {
    LightSum s;
    s.unused = 0;
#ifdef SHADING
    s.gl = length(g);
    s.N = s.gl > Lp->gradientMin ? -g / s.gl : (float3)(0.0f);
    s.V = -rayDir;
    if (dot(s.N, s.V) < 0.0f) s.N = -s.N;
    s.diffuse = (float3)(0.0f);
    s.specular = (float3)(0.0f);
#endif
#ifdef SCATTERING
    s.scattered = (float3)(0.0f);
#endif
    return s;
}

/* Adds light i arriving from unit direction L with visibility vis (shadow transmittance, 1 unshadowed). */
inline void light_add(LightSum* s, const VolclLightingParams* Lp, int i, float3 L, float vis, float3 rayDir) {
    const float3 lc = v3(Lp->lightColor[i]);
#ifdef SHADING
    if (s->gl > Lp->gradientMin) {
        const float3 H = normalize(L + s->V);
        s->diffuse += lc * vis * fmax(dot(s->N, L), 0.0f);
        s->specular += lc * vis * specular_power(fmax(dot(s->N, H), 0.0f), Lp->shininess);
    } else {
        s->diffuse +=
            lc * vis; /* no defined normal (flat region): lit as if facing the light, no highlight */
    }
#endif
#ifdef SCATTERING
    const float ct = dot(L, rayDir);
#ifdef MS_OCTAVES
    /* Multiple scattering approximated by octaves (Wrenninge et al. 2013): octave k scatters a^k of the
       light through the optical depth scaled by b^k with the phase of anisotropy c^k g; a = b = c = 1/2. */
    float ak = 1.0f, bk = 1.0f, g = Lp->phaseG, sum = 0.0f;
    for (int k = 0; k < MS_OCTAVES; ++k) {
        const float denom = 1.0f + g * g - 2.0f * g * ct;
        sum += ak * pow(vis, bk) * (1.0f - g * g) / (4.0f * M_PI_F * denom * sqrt(denom));
        ak *= 0.5f;
        bk *= 0.5f;
        g *= 0.5f;
    }
    s->scattered += lc * sum;
#else
    const float g = Lp->phaseG;
    const float denom = 1.0f + g * g - 2.0f * g * ct;
    const float phase = (1.0f - g * g) / (4.0f * M_PI_F * denom * sqrt(denom));
    s->scattered += lc * vis * phase;
#endif
#endif
}

/* Light reaching the eye from a sample of straight colour c. */
inline float3 light_finish(const LightSum* s, const VolclLightingParams* Lp, float3 c) {
    float3 out = (float3)(0.0f);
#ifdef SHADING
    out += c * (Lp->ambient + Lp->diffuse * s->diffuse) + Lp->specular * s->specular;
#elif !defined(NO_EMISSION) /* NO_EMISSION: a purely scattering medium (effects.scattering.emission false) */
    out += c;
#endif
#ifdef SCATTERING
    out += Lp->albedo * c * s->scattered;
#endif
    return out;
}

#endif
