/* Ray marcher: DVR (point sampled or pre-integrated), MIP, x-ray, emission, iso-surfaces; effects only when -D asks. */
#include "common/camera_rays.h"
#include "common/grid_sample.h"
#include "common/shading.h"
#include "common/tf_lookup.h"
#ifdef FOG
#include "common/fog.h"
#endif
#ifdef LABELS
#include "common/labels.h"
#endif

/* Compile-time features (the host defines exactly those a scene needs: planEffects in render/EffectPlan.cpp,
   VOXEL_TYPE and CORNER_VOXELS from render/grid/GridRenderer.cpp):
   MODE          0 dvr, 1 mip, 2 iso, 3 xray, 4 emission
   PREINT        0 point sampling, 2 2D table at the render step, 3 3D table over segment lengths
   SKIPPING      empty-space skipping with the macrocell grid
   EARLY_TERMINATION  stop when opacity reaches march.earlyTermination
   ISO_COUNT     iso-surfaces composited in ray order (iso mode, or mixed into dvr)
   SHADING       Blinn-Phong with lighting.lightCount lights (GRADIENT_SOBEL: Sobel instead of central differences)
   SHADOWS       transmittance to each light by secondary marching (SHADOW_VOLUME: one fetch in each light's
                 attenuation volume, cl/common/light_volume.h, built by cl/render/light_volume.cl)
   SCATTERING    single scattering, Henyey-Greenstein phase (NO_EMISSION: the TF colour only tints the scattered light;
                 MS_OCTAVES=n: multiple scattering approximated by n octaves)
   CLIPPING      clip.count clipping planes
   FILTER_BSPLINE  cubic B-spline samples and analytic gradients (the volume buffer holds its coefficients)
   MIP_COLOR     0 windowed grey, 1 TF colour brightened by the window, 2 TF colour and opacity
   FOG           height fog (fog.h) composited with the volume in ray order; FOG_MAP: base from a height map
   PREINT_LIGHTING  (PREINT 2, SHADING) shading through the pre-integrated lighting table: slices 1 and 2 of
                 the table buffer hold (front diffuse rgb, emission centroid) and (back diffuse rgb, 0)
   ISO_TABLE     (mode iso) surfaces from the iso-surface table (slice 0 of the table buffer) per segment
   GRADIENT_CACHE  (packet kernel, SHADING) gradients from the gradient cache (common/gradient_cache.h):
                 1 trilinear blend of the eight voxels' cached gradients, 2 the nearest voxel's, 3 the
                 trilinear blend of the exact form (integer voxels spanning at most 511)
   TF_GRADIENT   (dvr, point sampling) a gradient TF (common/tf_lookup.h, tf_gradient()): each sample also reads
                 its gradient magnitude (the gradient() of SHADING's kind); the per-ray kernel only
   LABELS        (dvr, point sampling) a label map classifies each sample with the TF (common/labels.h): 1 replace,
                 2 modulate, 3 alone; LABEL_NEAREST the nearest label voxel's, LABEL_SAME_GRID the label grid is
                 the volume's; the per-ray kernel only, with two more arguments (label voxels, label table) */
#ifndef MODE
#define MODE 0
#endif
#ifndef PREINT
#define PREINT 0
#endif
#ifndef MIP_COLOR
#define MIP_COLOR 0
#endif
#ifndef ISO_COUNT
#define ISO_COUNT 0
#endif
#if defined(SHADING) || defined(SCATTERING)
#define NEEDS_LIGHTS 1
#endif
#ifdef GRADIENT_CACHE
#include "common/gradient_cache.h"
#endif
/* The packet kernel serves dvr without iso-surfaces, unlit or Blinn-Phong shaded from the gradient cache. */
#if MODE == 0 && ISO_COUNT == 0 && !defined(TF_GRADIENT) && !defined(LABELS) &&                              \
    (!defined(NEEDS_LIGHTS) || (defined(GRADIENT_CACHE) && defined(SHADING) && !defined(SCATTERING) &&       \
                                (!defined(SHADOWS) || defined(SHADOW_VOLUME)) && !defined(PREINT_LIGHTING)))
#define PACKET_KERNEL 1
#endif

#ifdef SHADOW_VOLUME
#include "common/light_volume.h"
/* The light volumes' argument of the per-sample helpers below, present only when shadows read them. */
#define SHADOW_PARAMS , __global const float* lightVol
#define SHADOW_ARGS , lightVol
#else
#define SHADOW_PARAMS
#define SHADOW_ARGS
#endif

#ifdef NEEDS_LIGHTS
#ifdef SHADOWS
/* Transmittance from world point x toward a light, point sampled at lighting.shadowStep. */
inline float shadow_transmittance(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                                  const VolclGridRenderParams* P, float3 x, float3 L, float dist) {
    const float3 inv = v3(P->grid.invSpacing);
    const float3 o = (x - v3(P->grid.origin)) * inv, d = L * inv;
    const float3 hi = grid_hi(&P->grid);
    const float2 span = clip_box(o, d, hi, 0.0f, dist);
    if (!(span.y > span.x)) return 1.0f;
    const float h = P->lighting.shadowStep;
    float depth = 0.0f;
    for (float t = span.x + 0.5f * h; t < span.y; t += h) {
        const float len = fmin(h, span.y - (t - 0.5f * h));
        depth += tf_sample(knots, P->tf.knotCount, sample_volume(vol, &P->grid, o + t * d)).w * len;
#ifdef MS_OCTAVES
        /* The octaves see the depth scaled down by up to 2^(1 - MS_OCTAVES): block only what all of them would. */
        if (depth > 7.0f * (float)(1 << (MS_OCTAVES - 1))) return 0.0f;
#else
        if (depth > 7.0f) return 0.0f; /* below 1e-3: the light is blocked for display purposes */
#endif
    }
    return exp(-depth);
}

/* Transmittance toward light i from world point x (unit direction L, distance dist). */
inline float light_visibility(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                              const VolclGridRenderParams* P, uint i, float3 x, float3 L,
                              float dist SHADOW_PARAMS) {
#ifdef SHADOW_VOLUME
    return light_volume_sample(lightVol, &P->lightVolume, i,
                               (x - v3(P->grid.origin)) * v3(P->grid.invSpacing));
#else
    return shadow_transmittance(vol, knots, P, x, L, dist);
#endif
}
#endif

/* Light reaching the eye from a sample of straight colour c at world point x (voxel point p): the gradient
   and shadow rays from the grid, the lighting sum from common/shading.h. */
inline float3 light_sample(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                           const VolclGridRenderParams* P, const Ray* r, float3 x, float3 p,
                           float3 c SHADOW_PARAMS) {
#ifdef SHADING
    const float3 g = gradient(vol, &P->grid, p);
#else
    const float3 g = (float3)(0.0f);
#endif
    LightSum sum = light_begin(&P->lighting, g, r->dWorld);
    for (uint i = 0; i < P->lighting.lightCount; ++i) {
        float dist;
        const float3 L =
            light_dir(&P->lighting, P->camera.perspective, r->oWorld, r->dWorld, (int)i, x, &dist);
#ifdef SHADOWS
        const float vis = light_visibility(vol, knots, P, i, x, L, dist SHADOW_ARGS);
#else
        const float vis = 1.0f;
#endif
        light_add(&sum, &P->lighting, (int)i, L, vis, r->dWorld);
    }
    return light_finish(&sum, &P->lighting, c);
}
#endif

#ifdef SKIPPING
/* Macrocell index holding voxel point p and the ray parameter where the ray leaves that cell. */
inline uint macro_cell(const VolclGridRenderParams* P, const Ray* r, float t, float* exitT) {
    const float3 p = ray_at(r, t);
    const float B = (float)P->grid.macroDims[3];
    const int3 m =
        (int3)((int)P->grid.macroDims[0] - 1, (int)P->grid.macroDims[1] - 1, (int)P->grid.macroDims[2] - 1);
    const int3 c = clamp(convert_int3(floor(p / B)), (int3)(0), m);
    const float3 lo = convert_float3(c) * B;
    const float3 hiBox = grid_hi(&P->grid);
    const float3 hi = fmin(lo + B, hiBox);
    const float pa[3] = {p.x, p.y, p.z}, da[3] = {r->d.x, r->d.y, r->d.z};
    const float la[3] = {lo.x, lo.y, lo.z}, ha[3] = {hi.x, hi.y, hi.z};
    float e = INFINITY;
    for (int a = 0; a < 3; ++a) {
        if (da[a] > 0.0f)
            e = fmin(e, (ha[a] - pa[a]) / da[a]);
        else if (da[a] < 0.0f)
            e = fmin(e, (la[a] - pa[a]) / da[a]);
    }
    *exitT = t + fmax(e, 0.0f);
    return ((uint)c.z * P->grid.macroDims[1] + (uint)c.y) * P->grid.macroDims[0] + (uint)c.x;
}
#endif

#include "raymarch_iso.h"
#include "raymarch_iso_sampled.h"

#if defined(PREINT_LIGHTING) && PREINT == 2 && defined(SHADING)
/* Pre-integrated lighting (Guthe 1.3.4): the normal is taken linear along the segment, diffuse light is the
   table's front and back terms weighted by the diffuse factor at each end, specular is evaluated at the
   normal interpolated to the segment's emission centroid omega and weighted by the segment's opacity.
   e: the segment's associated (rgb, alpha); df, db: the table's raw front/back diffuse terms, scaled by
   `ratio` to the segment's length; x: the segment's world midpoint (shadow rays start there). */
inline float3 preint_light(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                           const VolclGridRenderParams* P, const Ray* r, float3 x, float3 gF, float3 gB,
                           float4 e, float3 df, float3 db, float omega, float ratio SHADOW_PARAMS) {
    const VolclLightingParams* Lp = &P->lighting;
    const float3 V = -r->dWorld;
    const float lf = length(gF), lb = length(gB);
    const bool vf = lf > Lp->gradientMin, vb = lb > Lp->gradientMin;
    float3 Nf = vf ? -gF / lf : (float3)(0.0f), Nb = vb ? -gB / lb : (float3)(0.0f);
    if (dot(Nf, V) < 0.0f) Nf = -Nf;
    if (dot(Nb, V) < 0.0f) Nb = -Nb;
    float3 Ns = vf && vb ? (1.0f - omega) * Nf + omega * Nb : vf ? Nf : Nb;
    const float ls = length(Ns);
    const bool vs = ls > 0.0f;
    if (vs) Ns /= ls;
    float3 diff = (float3)(0.0f), spec = (float3)(0.0f);
    for (uint i = 0; i < Lp->lightCount; ++i) {
        float dist;
        const float3 L = light_dir(Lp, P->camera.perspective, r->oWorld, r->dWorld, (int)i, x, &dist);
#ifdef SHADOWS
        const float vis = light_visibility(vol, knots, P, i, x, L, dist SHADOW_ARGS);
#else
        const float vis = 1.0f;
#endif
        const float3 lc = v3(Lp->lightColor[i]) * vis;
        diff += lc * ((vf ? fmax(dot(Nf, L), 0.0f) : 1.0f) * df + (vb ? fmax(dot(Nb, L), 0.0f) : 1.0f) * db);
        if (vs) spec += lc * specular_power(fmax(dot(Ns, normalize(L + V)), 0.0f), Lp->shininess);
    }
    return Lp->ambient * e.xyz + Lp->diffuse * ratio * diff + Lp->specular * e.w * spec;
}
#endif

#if ISO_COUNT > 0 && defined(ISO_TABLE)
/* Iso-surfaces through the iso-surface table (Roettger 8.13): entry (front, back) composites the surfaces
   crossed between the segment's end values. The table is a step function of its nodes, so each end takes
   its nearest node (interpolating would smear every surface into a ramp); shading at the segment's midpoint. */
inline void iso_table_segment(__global const float4* table, __global const voxel_t* vol,
                              __global const VolclTfKnot* knots, const VolclGridRenderParams* P, const Ray* r,
                              float t0, float s0, float t1, float s1, float3* rgb, float* T,
                              float* depth SHADOW_PARAMS) {
#ifdef NAN_COLOR
    if (!isfinite(s0) || !isfinite(s1)) return; /* a crossing needs finite ends */
#endif
    const VolclTfParams* Tp = &P->tf;
    const int n = (int)Tp->tableSize;
    const float scale = (float)(n - 1) / (Tp->domainHi - Tp->domainLo);
    const int i = clamp((int)rint((s0 - Tp->domainLo) * scale), 0, n - 1);
    const int j = clamp((int)rint((s1 - Tp->domainLo) * scale), 0, n - 1);
    const float4 e = table[(size_t)i * (size_t)n + (size_t)j];
    if (!(e.w > 0.0f)) return;
    const float tm = 0.5f * (t0 + t1);
    float3 c = e.xyz / e.w;
#ifdef NEEDS_LIGHTS
    c = light_sample(vol, knots, P, r, r->oWorld + tm * r->dWorld, ray_at(r, tm), c SHADOW_ARGS);
#endif
    if (isinf(*depth)) *depth = tm;
    *rgb += *T * e.w * c;
    *T *= 1.0f - e.w;
}
#endif

#ifdef LABELS
/* The label map's arguments of the kernel and of dvr_point_segment, present only with labels. */
#define LABEL_PARAMS , __global const ushort *labelVol, __global const float4 *labelTable
#define LABEL_ARGS , labelVol, labelTable
#else
#define LABEL_PARAMS
#define LABEL_ARGS
#endif

#ifdef FOG
/* The fog's arguments of the per-ray helpers below, present only when the kernel has fog. */
#define FOG_PARAMS , __global const float *fogMap, const FogRay *fr
#define FOG_ARGS , fogMap, &fr
#else
#define FOG_PARAMS
#define FOG_ARGS
#endif

#if MODE == 1
/* Maximum intensity projection: the largest sample on the ray, windowed to grey or coloured by the TF. */
inline float4 mip_ray(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                      const VolclGridRenderParams* P, const Ray* r, float tEnter, float tExit, float step,
                      int nseg) {
    float smax = -INFINITY;
    for (int k = 0; k <= nseg; ++k) {
        const float t = k == nseg ? tExit : tEnter + (float)k * step;
        const float s = sample_volume(vol, &P->grid, ray_at(r, t));
#ifdef NAN_COLOR
        if (!isfinite(s)) continue; /* MIP ignores samples that are not finite */
#endif
        smax = fmax(smax, s);
    }
#ifdef NAN_COLOR
    if (smax == -INFINITY) return (float4)(0.0f); /* no finite sample on the ray */
#endif
#if MIP_COLOR == 2
    const float4 e = tf_sample(knots, P->tf.knotCount, smax);
    const float a = 1.0f - exp(-e.w);
    return (float4)(e.xyz * a, a);
#else
    /* The window maps [centre - width/2, centre + width/2] to [0, 1]; the level is also the coverage, so
       over a black background the pixel is the window's grey and values below the window are transparent. */
    const float g = clamp((smax - P->march.windowLo) * P->march.windowInvWidth, 0.0f, 1.0f);
#if MIP_COLOR == 1
    return (float4)(tf_sample(knots, P->tf.knotCount, smax).xyz * g, g);
#else
    return (float4)(g, g, g, g);
#endif
#endif
}
#endif

#if MODE == 3
/* X-ray: the optical depth of the ray's segments (midpoint samples) and of the fog, as grey opacity. */
inline float4 xray_ray(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                       const VolclGridRenderParams* P, const Ray* r, float tEnter, float tExit, float step,
                       int nseg FOG_PARAMS) {
    float opticalDepth = 0.0f;
    for (int k = 0; k < nseg; ++k) {
        const float t0 = tEnter + (float)k * step, t1 = fmin(t0 + step, tExit);
        const float len = t1 - t0;
        const float s = sample_volume(vol, &P->grid, ray_at(r, t0 + 0.5f * len));
#ifdef NAN_COLOR
        if (!isfinite(s)) continue; /* x-ray ignores samples that are not finite */
#endif
        opticalDepth += tf_sample(knots, P->tf.knotCount, s).w * len;
    }
#ifdef FOG
    if (fr->span.y > fr->span.x) {
        float fd, fj;
        fog_interval(&P->fog, fogMap, fr, r->oWorld, r->dWorld, fr->span.x, fr->span.y, 0.0f, &fd, &fj);
        opticalDepth += fd;
    }
#endif
    const float a = 1.0f - exp(-opticalDepth);
    return (float4)(a, a, a, a);
}
#endif

#if MODE == 4
/* Emission only: the integral of the TF's emission c(s) tau(s) along the ray (midpoint samples), without
   absorption. Alpha is 0: the light adds to the background. */
inline float4 emission_ray(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                           const VolclGridRenderParams* P, const Ray* r, float tEnter, float tExit,
                           float step, int nseg) {
    float3 sum = (float3)(0.0f);
    for (int k = 0; k < nseg; ++k) {
        const float t0 = tEnter + (float)k * step, t1 = fmin(t0 + step, tExit);
        const float len = t1 - t0;
        const float s = sample_volume(vol, &P->grid, ray_at(r, t0 + 0.5f * len));
#ifdef NAN_COLOR
        if (!isfinite(s)) continue; /* emission ignores samples that are not finite */
#endif
        const float4 e = tf_sample(knots, P->tf.knotCount, s);
        sum += e.xyz * (e.w * len);
    }
    return (float4)(sum, 0.0f);
}
#endif

#if MODE == 0 && PREINT == 0
/* A dvr segment [t0, t1] of length len sampled at its midpoint (lit when the scene has lights) and
   composited into (rgb, T), with the fog over it. */
inline void dvr_point_segment(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                              const VolclGridRenderParams* P, const Ray* r, float t0, float t1, float len,
                              float3* rgb, float* T FOG_PARAMS SHADOW_PARAMS LABEL_PARAMS) {
    const float tm = t0 + 0.5f * len;
    const float3 pm = ray_at(r, tm);
#ifdef LABELS
    const float4 e = label_sample(labelVol, labelTable, &P->labels, pm,
                                  tf_sample(knots, P->tf.knotCount, sample_volume(vol, &P->grid, pm)));
#elif defined(TF_GRADIENT)
    const float s = sample_volume(vol, &P->grid, pm);
    float4 e = tf_sample(knots, P->tf.knotCount, s);
    if (tf_gradient_needed(knots, &P->tf, s, e))
        e = tf_gradient(knots, &P->tf, s, e, length(gradient(vol, &P->grid, pm)));
#else
    const float4 e = tf_sample(knots, P->tf.knotCount, sample_volume(vol, &P->grid, pm));
#endif
    const float a = 1.0f - exp(-e.w * len);
    float3 c = e.xyz;
#ifdef NEEDS_LIGHTS
    if (a > 0.0f) c = light_sample(vol, knots, P, r, r->oWorld + tm * r->dWorld, pm, c SHADOW_ARGS);
#endif
#ifdef FOG
    fog_with_segment(&P->fog, fogMap, fr, r->oWorld, r->dWorld, t0, t1, e.w, c, rgb, T);
#else
    *rgb += *T * a * c;
    *T *= 1.0f - a;
#endif
}
#endif

#if MODE == 0 && PREINT != 0
/* A dvr segment [t0, t1] of length len between the samples sPrev and sNext through the pre-integration table (lit
   when the scene has lights: pre-integrated lighting carries the back gradient to the next segment in gPrev)
   and composited into (rgb, T), with the fog over it. */
inline void dvr_preint_segment(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                               __global const float4* table, const VolclGridRenderParams* P, const Ray* r,
                               float t0, float t1, float len, float sPrev, float sNext, float3* gPrev,
                               int* gPrevValid, float3* rgb, float* T FOG_PARAMS SHADOW_PARAMS) {
#ifdef NAN_COLOR
    /* A segment with an end that is not finite is a constant segment of the NaN colour, unlit. */
    if (!isfinite(sPrev) || !isfinite(sNext)) {
        *gPrevValid = 0;
#ifdef FOG
        fog_with_segment(&P->fog, fogMap, fr, r->oWorld, r->dWorld, t0, t1, NAN_TAU,
                         (float3)(NAN_R, NAN_G, NAN_B), rgb, T);
#else
        const float an = 1.0f - exp(-NAN_TAU * len);
        *rgb += *T * an * (float3)(NAN_R, NAN_G, NAN_B);
        *T *= 1.0f - an;
#endif
        return;
    }
#endif
    const float4 e = preint_segment(table, &P->tf, sPrev, sNext, len);
    float3 c = e.xyz;
#if defined(PREINT_LIGHTING) && PREINT == 2 && defined(SHADING)
    if (e.w > 0.0f) {
        const float sc = (float)(P->tf.tableSize - 1) / (P->tf.domainHi - P->tf.domainLo);
        const float u = (sPrev - P->tf.domainLo) * sc, v = (sNext - P->tf.domainLo) * sc;
        const float4 e0 = table_bilinear(table, P->tf.tableSize, 0, u, v);
        const float4 lf = table_bilinear(table, P->tf.tableSize, 1, u, v);
        const float4 lb = table_bilinear(table, P->tf.tableSize, 2, u, v);
        const float ratio = e0.w > 0.0f ? e.w / e0.w : len / P->tf.tableMaxLength;
        const float3 gF = *gPrevValid ? *gPrev : gradient(vol, &P->grid, ray_at(r, t0));
        const float3 gB = gradient(vol, &P->grid, ray_at(r, t1));
        *gPrev = gB;
        *gPrevValid = 1;
        c = preint_light(vol, knots, P, r, r->oWorld + (t0 + 0.5f * len) * r->dWorld, gF, gB, e, lf.xyz,
                         lb.xyz, clamp(lf.w, 0.0f, 1.0f), ratio SHADOW_ARGS);
    } else {
        *gPrevValid = 0;
    }
#elif defined(NEEDS_LIGHTS)
    /* The segment lit at its midpoint as a sample of straight colour rgb / alpha, weighted by alpha as
       the point-sampled path weights its sample (the specular term is not a colour to scale: lighting
       the associated colour added it once per segment whatever the segment's opacity). */
    if (e.w > 0.0f) {
        const float tm = t0 + 0.5f * len;
        c = light_sample(vol, knots, P, r, r->oWorld + tm * r->dWorld, ray_at(r, tm), c / e.w SHADOW_ARGS) *
            e.w;
    }
#endif
#ifdef FOG
    /* The segment as a medium of constant extinction with its optical depth and straight colour, mixed
       with the fog over it exactly for that medium (exact whenever either is absent). */
    const float av = clamp(e.w, 0.0f, 1.0f - 1e-7f);
    const float tauV = av > 0.0f ? -log1p(-av) / len : 0.0f;
    fog_with_segment(&P->fog, fogMap, fr, r->oWorld, r->dWorld, t0, t1, tauV,
                     av > 0.0f ? c / e.w : (float3)(0.0f), rgb, T);
#else
    *rgb += *T * c;
    *T *= 1.0f - e.w;
#endif
}
#endif

__kernel void raymarch(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                       __global const float4* table, __global const uchar* macroEmpty,
                       const VolclGridRenderParams params, __global float4* out, __global float* depthOut,
                       __global const float* fogMap, __global const float* lightVol,
                       __global const uint* gradCache LABEL_PARAMS) {
    (void)gradCache; /* the packet kernel's */
    const uint x = get_global_id(0), y = get_global_id(1);
#ifndef SHADOW_VOLUME
    (void)lightVol;
#endif
    if (x >= params.camera.width || y >= params.camera.height) return;
    const VolclGridRenderParams* P = &params;
    const Ray r = grid_ray(&P->grid, camera_ray_world(&P->camera, x, y));
    const float3 hi = grid_hi(&P->grid);
    float2 span = clip_box(r.o, r.d, hi, 0.0f, INFINITY);
#ifdef CLIPPING
    clip_planes(&P->clip, r.oWorld, r.dWorld, &span);
#endif
    float3 rgb = (float3)(0.0f);
    float T = 1.0f;
    float depth = INFINITY;
    const size_t pix = (size_t)y * params.camera.width + x;
#ifdef FOG
    /* The fog's own box may reach beyond the volume's: fog alone in front of and behind the volume span. */
    const FogRay fr = fog_ray(&P->fog, r.oWorld, r.dWorld);
    if (!(span.y > span.x)) {
#if MODE == 3
        float fd, fj;
        fog_interval(&P->fog, fogMap, &fr, r.oWorld, r.dWorld, fr.span.x, fr.span.y, 0.0f, &fd, &fj);
        const float fa = fr.span.y > fr.span.x ? -expm1(-fd) : 0.0f;
        out[pix] = (float4)(fa, fa, fa, fa);
#else
        if (fr.span.y > fr.span.x)
            fog_only(&P->fog, fogMap, &fr, r.oWorld, r.dWorld, fr.span.x, fr.span.y, &rgb, &T);
        out[pix] = (float4)(rgb, 1.0f - T);
#endif
#if ISO_COUNT > 0
        depthOut[pix] = INFINITY;
#endif
        return;
    }
#if MODE != 3
    if (fr.span.y > fr.span.x)
        fog_only(&P->fog, fogMap, &fr, r.oWorld, r.dWorld, fr.span.x, fmin(fr.span.y, span.x), &rgb, &T);
#endif
#else
    (void)fogMap;
    if (!(span.y > span.x)) {
        out[pix] = (float4)(0.0f);
#if ISO_COUNT > 0
        depthOut[pix] = INFINITY;
#endif
        return;
    }
#endif
    const float tEnter = span.x, tExit = span.y, step = P->march.step;
    const float lenTotal = tExit - tEnter;
    const int nseg = max((int)ceil(lenTotal / step), 1);
    float4 result;

#if MODE == 1 /* ---------------- maximum intensity projection ---------------- */
    result = mip_ray(vol, knots, P, &r, tEnter, tExit, step, nseg);

#elif MODE == 3 /* ---------------- x-ray: absorption only ---------------- */
    result = xray_ray(vol, knots, P, &r, tEnter, tExit, step, nseg FOG_ARGS);

#elif MODE == 4 /* ---------------- emission only ---------------- */
    result = emission_ray(vol, knots, P, &r, tEnter, tExit, step, nseg);

#else /* ---------------- dvr and iso: front-to-back compositing ---------------- */
#if PREINT != 0 || ISO_COUNT > 0
    float sPrev = sample_volume(vol, &P->grid, ray_at(&r, tEnter));
#endif
#ifdef SKIPPING
    float cellExit = -INFINITY;
#endif
#if MODE == 0 && PREINT != 0
    float3 gPrev = (float3)(0.0f);
    int gPrevValid =
        0;        /* pre-integrated lighting: the last segment's back gradient is this one's front gradient */
#endif
#if ISO_COUNT > 0 && !defined(FILTER_BSPLINE) && !defined(ISO_TABLE)
    IsoState iso; /* the iso-surfaces' cell walk carries over from segment to segment */
    iso_begin(&iso, &r);
#endif
    int k = 0;
    while (k < nseg) {
        const float t0 = tEnter + (float)k * step;
#ifdef SKIPPING
        if (t0 >= cellExit) {
            float exitT;
            const uint cell = macro_cell(P, &r, t0, &exitT);
            cellExit = exitT;
            if (macroEmpty[cell]) {
                /* Segments with both ends in an empty cell add nothing: jump to the last one starting in it. */
                const int j = min((int)floor((exitT - tEnter) / step), nseg);
                if (j > k) {
#ifdef FOG
                    fog_only(&P->fog, fogMap, &fr, r.oWorld, r.dWorld, t0,
                             j == nseg ? tExit : fmin(tEnter + (float)j * step, tExit), &rgb, &T);
#endif
#if defined(PREINT_LIGHTING) && PREINT == 2 && defined(SHADING)
                    gPrevValid = 0;
#endif
                    k = j;
#if PREINT != 0 || ISO_COUNT > 0
                    if (k < nseg) sPrev = sample_volume(vol, &P->grid, ray_at(&r, tEnter + (float)k * step));
#endif
                    continue;
                }
            }
        }
#endif
        const float t1 = k == nseg - 1 ? tExit : fmin(t0 + step, tExit);
        const float len = t1 - t0;
#if PREINT != 0 || ISO_COUNT > 0
        const float sNext = sample_volume(vol, &P->grid, ray_at(&r, t1));
#endif
#if ISO_COUNT > 0 && defined(ISO_TABLE)
        iso_table_segment(table, vol, knots, P, &r, t0, sPrev, t1, sNext, &rgb, &T, &depth SHADOW_ARGS);
#elif ISO_COUNT > 0 && defined(FILTER_BSPLINE)
        iso_sampled_segment(vol, knots, P, &r, t0, sPrev, t1, sNext, &rgb, &T, &depth SHADOW_ARGS);
#elif ISO_COUNT > 0
        iso_march(vol, knots, P, &r, &iso, t0, t1, &rgb, &T, &depth SHADOW_ARGS);
#endif
#if MODE == 2 && defined(FOG)
        /* A surface inside this step is composited in front of the step's fog. */
        fog_only(&P->fog, fogMap, &fr, r.oWorld, r.dWorld, t0, t1, &rgb, &T);
#endif
#if MODE == 0 && PREINT == 0
        dvr_point_segment(vol, knots, P, &r, t0, t1, len, &rgb, &T FOG_ARGS SHADOW_ARGS LABEL_ARGS);
#elif MODE == 0
        dvr_preint_segment(vol, knots, table, P, &r, t0, t1, len, sPrev, sNext, &gPrev, &gPrevValid, &rgb,
                           &T FOG_ARGS SHADOW_ARGS);
#endif
#if PREINT != 0 || ISO_COUNT > 0
        sPrev = sNext;
#endif
#ifdef EARLY_TERMINATION
        if (1.0f - T >= P->march.earlyTermination) break;
#endif
        ++k;
    }
#ifdef FOG
#ifdef EARLY_TERMINATION
    if (!(1.0f - T >= P->march.earlyTermination))
#endif
        if (fr.span.y > fr.span.x)
            fog_only(&P->fog, fogMap, &fr, r.oWorld, r.dWorld, fmax(fr.span.x, tExit), fr.span.y, &rgb, &T);
#endif
    result = (float4)(rgb, 1.0f - T);
#endif
    out[pix] = result;
#if ISO_COUNT > 0
    depthOut[pix] = depth;
#endif
}

#ifdef PACKET_KERNEL
/* Macrocells of a packet at ray parameter t: index and the parameter where each ray leaves its cell
   (macro_cell per lane, vectorised). */
PACKET_INLINE uint8 macro_cell8(const VolclGridRenderParams* P, const RayPacket* r, float8 t, float8* exitT) {
    const float8 px = r->ox + t * r->dx, py = r->oy + t * r->dy, pz = r->oz + t * r->dz;
    const float B = (float)P->grid.macroDims[3];
    /* vector bounds: see sample_volume8 */
    const int8 cx = clamp(convert_int8(floor(px / B)), (int8)(0), (int8)((int)P->grid.macroDims[0] - 1));
    const int8 cy = clamp(convert_int8(floor(py / B)), (int8)(0), (int8)((int)P->grid.macroDims[1] - 1));
    const int8 cz = clamp(convert_int8(floor(pz / B)), (int8)(0), (int8)((int)P->grid.macroDims[2] - 1));
    const float8 lx = convert_float8(cx) * B, ly = convert_float8(cy) * B, lz = convert_float8(cz) * B;
    const float8 hx = fmin(lx + B, (float)(P->grid.dims[0] - 1)),
                 hy = fmin(ly + B, (float)(P->grid.dims[1] - 1)),
                 hz = fmin(lz + B, (float)(P->grid.dims[2] - 1));
    float8 e = (float8)(INFINITY);
    e = select(e, fmin(e, (hx - px) / r->dx), r->dx > 0.0f);
    e = select(e, fmin(e, (lx - px) / r->dx), r->dx < 0.0f);
    e = select(e, fmin(e, (hy - py) / r->dy), r->dy > 0.0f);
    e = select(e, fmin(e, (ly - py) / r->dy), r->dy < 0.0f);
    e = select(e, fmin(e, (hz - pz) / r->dz), r->dz > 0.0f);
    e = select(e, fmin(e, (lz - pz) / r->dz), r->dz < 0.0f);
    *exitT = t + fmax(e, 0.0f);
    return (convert_uint8(cz) * P->grid.macroDims[1] + convert_uint8(cy)) * P->grid.macroDims[0] +
           convert_uint8(cx);
}

#ifdef FOG
/* Fog of a packet, lane by lane: each lane's fog ray fr[l] (world origin fo[l], direction fd[l]) composited
   into the packet's colour (cr, cg, cb) and transmittance T. */

/* Over the empty cells the lanes in `jump` skip: from t0 to the start of their segment j. */
PACKET_INLINE void fog_skip_packet(const VolclGridRenderParams* P, __global const float* fogMap,
                                   const FogRay* fr, const float3* fo, const float3* fd, const LaneF* enter,
                                   const LaneI* nsegL, int8 jump, int8 j, float8 t0, float8 tExit, float step,
                                   float8* cr, float8* cg, float8* cb, float8* T) {
    LaneI jl, jj;
    LaneF t0l, tx, R, G, Bq, TT;
    jl.v = jump;
    jj.v = j;
    t0l.v = t0;
    tx.v = tExit;
    R.v = *cr;
    G.v = *cg;
    Bq.v = *cb;
    TT.v = *T;
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        if (!jl.a[l]) continue;
        const float tj =
            jj.a[l] >= nsegL->a[l] ? tx.a[l] : fmin(enter->a[l] + (float)jj.a[l] * step, tx.a[l]);
        float3 c3 = (float3)(R.a[l], G.a[l], Bq.a[l]);
        fog_only(&P->fog, fogMap, &fr[l], fo[l], fd[l], t0l.a[l], tj, &c3, &TT.a[l]);
        R.a[l] = c3.x;
        G.a[l] = c3.y;
        Bq.a[l] = c3.z;
    }
    *cr = R.v;
    *cg = G.v;
    *cb = Bq.v;
    *T = TT.v;
}

/* Over each active lane's step [t0, t1], composited with the segment (er, eg, eb, ea: point sampled
   extinction and colour, or the pre-integrated associated colour and opacity) as fog.h mixes them. */
PACKET_INLINE void fog_segment_packet(const VolclGridRenderParams* P, __global const float* fogMap,
                                      const FogRay* fr, const float3* fo, const float3* fd, int8 active,
                                      float8 t0, float8 t1, const LaneF* er, const LaneF* eg, const LaneF* eb,
                                      const LaneF* ea, float8* cr, float8* cg, float8* cb, float8* T) {
    LaneI al;
    LaneF t0l, t1l, R, G, Bq, TT;
    al.v = active;
    t0l.v = t0;
    t1l.v = t1;
    R.v = *cr;
    G.v = *cg;
    Bq.v = *cb;
    TT.v = *T;
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        if (!al.a[l]) continue;
        float3 c3 = (float3)(R.a[l], G.a[l], Bq.a[l]);
#if PREINT == 0
        const float tauV = ea->a[l];
        const float3 cv = (float3)(er->a[l], eg->a[l], eb->a[l]);
#else
        const float av = clamp(ea->a[l], 0.0f, 1.0f - 1e-7f);
        const float tauV = av > 0.0f ? -log1p(-av) / (t1l.a[l] - t0l.a[l]) : 0.0f;
        const float3 cv = av > 0.0f ? (float3)(er->a[l], eg->a[l], eb->a[l]) / ea->a[l] : (float3)(0.0f);
#endif
        fog_with_segment(&P->fog, fogMap, &fr[l], fo[l], fd[l], t0l.a[l], t1l.a[l], tauV, cv, &c3, &TT.a[l]);
        R.a[l] = c3.x;
        G.a[l] = c3.y;
        Bq.a[l] = c3.z;
    }
    *cr = R.v;
    *cg = G.v;
    *cb = Bq.v;
    *T = TT.v;
}

/* Behind the volume: from each lane's exit tExit to the end of its fog (lanes that missed the volume had all
   their fog up front). */
PACKET_INLINE void fog_tail_packet(const VolclGridRenderParams* P, __global const float* fogMap,
                                   const FogRay* fr, const float3* fo, const float3* fd, const LaneI* nsegL,
                                   float8 tExit, float8* cr, float8* cg, float8* cb, float8* T) {
    LaneF R, G, Bq, TT, tx;
    R.v = *cr;
    G.v = *cg;
    Bq.v = *cb;
    TT.v = *T;
    tx.v = tExit;
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        if (nsegL->a[l] == 0 || !(fr[l].span.y > fr[l].span.x))
            continue; /* missed volume: all done up front */
#ifdef EARLY_TERMINATION
        if (1.0f - TT.a[l] >= P->march.earlyTermination) continue;
#endif
        float3 c3 = (float3)(R.a[l], G.a[l], Bq.a[l]);
        fog_only(&P->fog, fogMap, &fr[l], fo[l], fd[l], fmax(fr[l].span.x, tx.a[l]), fr[l].span.y, &c3,
                 &TT.a[l]);
        R.a[l] = c3.x;
        G.a[l] = c3.y;
        Bq.a[l] = c3.z;
    }
    *cr = R.v;
    *cg = G.v;
    *cb = Bq.v;
    *T = TT.v;
}
#endif

#ifdef GRADIENT_CACHE
/* specular_power (common/shading.h) for eight bases and one exponent: the same squarings in every lane. */
PACKET_INLINE float8 specular_power8(float8 x, float n) {
    float8 r;
    if (n == floor(n) && n <= 1024.0f) {
        uint e = (uint)n;
        float8 b = x;
        r = (float8)(1.0f);
        while (e) {
            if (e & 1u) r *= b;
            b *= b;
            e >>= 1;
        }
    } else {
        r = exp2(n * log2(x));
    }
    return select(select((float8)(0.0f), (float8)(1.0f), (int8)(n == 0.0f ? -1 : 0)), r, x > 0.0f);
}

#ifdef SHADOW_VOLUME
/* light_volume_sample (common/light_volume.h) for the eight lanes at voxel coordinates (px, py, pz): the same
   clamps and lerps, gathered lane by lane and blended and exponentiated in float8. */
PACKET_INLINE float8 light_volume_sample8(__global const float* lv, const VolclLightVolumeParams* V, uint i,
                                          float8 px, float8 py, float8 pz) {
    const int hx = (int)V->dims[0] - 1, hy = (int)V->dims[1] - 1, hz = (int)V->dims[2] - 1;
    const float8 qx = clamp(px * V->toLight[0], 0.0f, (float)hx);
    const float8 qy = clamp(py * V->toLight[1], 0.0f, (float)hy);
    const float8 qz = clamp(pz * V->toLight[2], 0.0f, (float)hz);
    const int8 ix = min(convert_int8(floor(qx)), (int8)(max(hx - 1, 0)));
    const int8 iy = min(convert_int8(floor(qy)), (int8)(max(hy - 1, 0)));
    const int8 iz = min(convert_int8(floor(qz)), (int8)(max(hz - 1, 0)));
    const float8 fx = qx - convert_float8(ix), fy = qy - convert_float8(iy), fz = qz - convert_float8(iz);
    const uint nx = V->dims[0], nxy = V->dims[0] * V->dims[1];
    __global const float* base = lv + (size_t)i * V->dims[3];
    LaneU x0, x1, y0, y1, z0, z1;
    x0.v = convert_uint8(ix);
    x1.v = convert_uint8(min(ix + 1, (int8)(hx)));
    y0.v = convert_uint8(iy) * nx;
    y1.v = convert_uint8(min(iy + 1, (int8)(hy))) * nx;
    z0.v = convert_uint8(iz) * nxy;
    z1.v = convert_uint8(min(iz + 1, (int8)(hz))) * nxy;
    LaneF a00, e00, a10, e10, a01, e01, a11, e11;
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        a00.a[l] = base[z0.a[l] + y0.a[l] + x0.a[l]];
        e00.a[l] = base[z0.a[l] + y0.a[l] + x1.a[l]];
        a10.a[l] = base[z0.a[l] + y1.a[l] + x0.a[l]];
        e10.a[l] = base[z0.a[l] + y1.a[l] + x1.a[l]];
        a01.a[l] = base[z1.a[l] + y0.a[l] + x0.a[l]];
        e01.a[l] = base[z1.a[l] + y0.a[l] + x1.a[l]];
        a11.a[l] = base[z1.a[l] + y1.a[l] + x0.a[l]];
        e11.a[l] = base[z1.a[l] + y1.a[l] + x1.a[l]];
    }
    const float8 c00 = a00.v + fx * (e00.v - a00.v), c10 = a10.v + fx * (e10.v - a10.v);
    const float8 c01 = a01.v + fx * (e01.v - a01.v), c11 = a11.v + fx * (e11.v - a11.v);
    const float8 c0 = c00 + fy * (c10 - c00), c1 = c01 + fy * (c11 - c01);
    return exp(-(c0 + fz * (c1 - c0)));
}
#endif

/* Blinn-Phong for the lanes in `lit` at ray parameter t, in float8: light_begin / light_add / light_finish of
   common/shading.h with the same formulas (visibility from the light volumes with SHADOW_VOLUME, else 1), the gradient from
   one cached-gradient blend. Lane l's world ray: wo[l] + t wd[l]. (er, eg, eb) hold straight colours;
   `assoc`: they are associated with opacity ea (pre-integrated segments), lit as straight colours and
   re-associated, as dvr_preint_segment does. */
PACKET_INLINE void shade_packet(__global const uint* gradCache, const VolclGridRenderParams* P,
                                const RayPacket* rp, const float3* wo, const float3* wd, const LaneF* vx,
                                const LaneF* vy, const LaneF* vz, float8 t, int8 lit, int assoc, LaneF* er,
                                LaneF* eg, LaneF* eb, const LaneF* ea SHADOW_PARAMS) {
    const VolclLightingParams* Lp = &P->lighting;
    float8 gx, gy, gz;
    const float8 px = rp->ox + t * rp->dx, py = rp->oy + t * rp->dy, pz = rp->oz + t * rp->dz;
    gcache_gradient8(gradCache, &P->grid, px, py, pz, &gx, &gy, &gz);
    /* The normal -g / |g| turned toward the eye is sg g / |g| with sg = +1 where g.v > 0, else -1: every dot
       product below is taken with g and scaled once by sg / |g| (one reciprocal square root, no normalised
       vector). A zero gradient (|g| <= gradientMin) is lit as facing the light. */
    const float8 gg = gx * gx + gy * gy + gz * gz;
    const int8 valid = gg > Lp->gradientMin * Lp->gradientMin;
    const float8 a = Lp->ambient;
    if (Lp->lightCount == 1u && Lp->lightPos[0][3] == VOLCL_LIGHT_HEAD && !P->camera.perspective) {
        /* The default light alone (one head light, orthographic): L = H = V, so N.l = N.h = |g.v| / |g| =
           sqrt(c2) with c2 = (g.v)^2 / |g|^2, and (N.h)^n = c2^(n/2): one division and one square root instead
           of a reciprocal square root with its Newton step, one squaring less, and no light loop (measured:
           bench/results/rendering/shading-variants-2-mri-512-load9.txt). */
        const float8 gv = gx * vx->v + gy * vy->v + gz * vz->v;
        const float8 c2 = select((float8)(0.0f), gv * gv / gg, valid);
        float8 diffuse = select((float8)(1.0f), sqrt(c2), valid); /* flat: as facing the light */
        float8 spec = select((float8)(0.0f), specular_power8(c2, 0.5f * Lp->shininess), valid);
#ifdef SHADOW_VOLUME
        const float8 vis = light_volume_sample8(lightVol, &P->lightVolume, 0, px, py, pz);
        diffuse *= vis;
        spec *= vis;
#endif
        const float3 lc = v3(Lp->lightColor[0]);
        const float8 w = assoc ? Lp->specular * ea->v : (float8)(Lp->specular);
        er->v = select(er->v, er->v * (a + Lp->diffuse * lc.x * diffuse) + w * lc.x * spec, lit);
        eg->v = select(eg->v, eg->v * (a + Lp->diffuse * lc.y * diffuse) + w * lc.y * spec, lit);
        eb->v = select(eb->v, eb->v * (a + Lp->diffuse * lc.z * diffuse) + w * lc.z * spec, lit);
        return;
    }
    float8 r = native_rsqrt(gg);
    r = r * (1.5f - 0.5f * gg * r * r); /* one Newton step: about 23 bits */
    const float8 gv = gx * vx->v + gy * vy->v + gz * vz->v;
    const float8 k = select((float8)(0.0f), select(-r, r, gv > 0.0f), valid);
    float8 dr = (float8)(0.0f), dg = dr, db = dr, sr = dr, sg = dr, sb = dr;
    for (uint i = 0; i < Lp->lightCount; ++i) {
        const float kind = Lp->lightPos[i][3];
        float8 ndotl, ndoth;
        if (kind == VOLCL_LIGHT_HEAD && !P->camera.perspective) {
            /* L = V: the half vector is V itself, so N.h = N.l = |g.v| / |g| */
            ndotl = gv * k;
            ndoth = ndotl;
        } else if (kind == VOLCL_LIGHT_DIRECTIONAL && !P->camera.perspective) {
            /* L and V are the same in every lane: the half vector once per packet */
            const float3 L = v3(Lp->lightPos[i]), V = (float3)(vx->a[0], vy->a[0], vz->a[0]);
            const float3 H = L + V;
            const float hl = length(H);
            ndotl = (gx * L.x + gy * L.y + gz * L.z) * k;
            ndoth = hl > 0.0f ? (gx * H.x + gy * H.y + gz * H.z) * (k / hl) : (float8)(0.0f);
        } else {
            LaneF lx, ly, lz;
            if (kind == VOLCL_LIGHT_DIRECTIONAL) { /* the same direction in every lane */
                lx.v = (float8)(Lp->lightPos[i][0]);
                ly.v = (float8)(Lp->lightPos[i][1]);
                lz.v = (float8)(Lp->lightPos[i][2]);
            } else {
                LaneF tl;
                tl.v = t;
                _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
                    float dist;
                    const float3 L = light_dir(Lp, P->camera.perspective, wo[l], wd[l], (int)i,
                                               wo[l] + tl.a[l] * wd[l], &dist);
                    lx.a[l] = L.x;
                    ly.a[l] = L.y;
                    lz.a[l] = L.z;
                }
            }
            const float8 hx = lx.v + vx->v, hy = ly.v + vy->v, hz = lz.v + vz->v;
            const float8 hl = sqrt(hx * hx + hy * hy + hz * hz);
            ndotl = (gx * lx.v + gy * ly.v + gz * lz.v) * k;
            ndoth = select((float8)(0.0f), (gx * hx + gy * hy + gz * hz) * k / hl, hl > 0.0f);
        }
        float8 diffuse = select((float8)(1.0f), fmax(ndotl, 0.0f), valid); /* flat: as facing the light */
        float8 spec = select((float8)(0.0f), specular_power8(fmax(ndoth, 0.0f), Lp->shininess), valid);
#ifdef SHADOW_VOLUME
        {
            /* Transmittance toward the light: one light-volume fetch per lane, as light_visibility does. */
            const float8 vis = light_volume_sample8(lightVol, &P->lightVolume, i, px, py, pz);
            diffuse *= vis;
            spec *= vis;
        }
#endif
        const float3 lc = v3(Lp->lightColor[i]);
        dr += lc.x * diffuse;
        dg += lc.y * diffuse;
        db += lc.z * diffuse;
        sr += lc.x * spec;
        sg += lc.y * spec;
        sb += lc.z * spec;
    }
    /* Associated colours: (c / w lit) * w, with the division cancelled: c (ambient + diffuse) + specular w. */
    const float8 w = assoc ? Lp->specular * ea->v : (float8)(Lp->specular);
    er->v = select(er->v, er->v * (a + Lp->diffuse * dr) + w * sr, lit);
    eg->v = select(eg->v, eg->v * (a + Lp->diffuse * dg) + w * sg, lit);
    eb->v = select(eb->v, eb->v * (a + Lp->diffuse * db) + w * sb, lit);
}
#endif

/* DVR (point sampled or pre-integrated, skipping, early termination, clipping, fog, and Blinn-Phong from the
   gradient cache) for a 4x2 block of pixels per work-item; the host launches it instead of `raymarch` when
   PACKET_KERNEL holds. Same image as `raymarch` with the same gradients. */
/* The TF's emission (rgb) and extinction (a) at each lane's sample s. */
inline void tf_packet(__global const VolclTfKnot* knots, const VolclGridRenderParams* P, float8 s, LaneF* er,
                      LaneF* eg, LaneF* eb, LaneF* ea) {
    LaneF sl;
    sl.v = s;
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const float4 e = tf_sample(knots, P->tf.knotCount, sl.a[l]);
        er->a[l] = e.x;
        eg->a[l] = e.y;
        eb->a[l] = e.z;
        ea->a[l] = e.w;
    }
}

/* Writes the packet's premultiplied colours and opacity 1 - T to the lanes' pixels inside the image. */
inline void store_packet(__global float4* out, const VolclGridRenderParams* P, uint x0, uint y0, float8 cr,
                         float8 cg, float8 cb, float8 T) {
    LaneF R, G, Bc, A;
    R.v = cr;
    G.v = cg;
    Bc.v = cb;
    A.v = 1.0f - T;
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const uint x = x0 + (uint)(l % PACKET_W), y = y0 + (uint)(l / PACKET_W);
        if (x < P->camera.width && y < P->camera.height)
            out[(size_t)y * P->camera.width + x] = (float4)(R.a[l], G.a[l], Bc.a[l], A.a[l]);
    }
}

__kernel void raymarch_packet(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                              __global const float4* table, __global const uchar* macroEmpty,
                              const VolclGridRenderParams params, __global float4* out,
                              __global float* depthOut, __global const float* fogMap,
                              __global const float* lightVol, __global const uint* gradCache) {
    (void)lightVol; /* read by shade_packet with SHADOW_VOLUME */
    const VolclGridRenderParams* P = &params;
    const uint x0 = get_global_id(0) * PACKET_W, y0 = get_global_id(1) * PACKET_H;
    if (x0 >= params.camera.width || y0 >= params.camera.height) return;
    const float3 hi = grid_hi(&P->grid);
    RayPacket rp;
    LaneF ox, oy, oz, dx, dy, dz, enter, exit;
    LaneI nsegL, act;
#ifdef FOG
    FogRay fr[RAY_LANES];
    float3 fo[RAY_LANES], fd[RAY_LANES];
    LaneF fR, fG, fB, fTT;
#else
    (void)fogMap;
#endif
#ifdef GRADIENT_CACHE
    float3 wo[RAY_LANES], wd[RAY_LANES]; /* the lanes' world rays, for the lights */
    LaneF vx, vy, vz;                    /* toward the eye: -wd */
#else
    (void)gradCache;
#endif
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const uint x = x0 + (uint)(l % PACKET_W), y = y0 + (uint)(l / PACKET_W);
        const Ray r = grid_ray(&P->grid, camera_ray_world(&P->camera, min(x, params.camera.width - 1),
                                                          min(y, params.camera.height - 1)));
        float2 span = clip_box(r.o, r.d, hi, 0.0f, INFINITY);
#ifdef CLIPPING
        clip_planes(&P->clip, r.oWorld, r.dWorld, &span);
#endif
        const bool on = x < params.camera.width && y < params.camera.height && span.y > span.x;
        ox.a[l] = r.o.x;
        oy.a[l] = r.o.y;
        oz.a[l] = r.o.z;
        dx.a[l] = r.d.x;
        dy.a[l] = r.d.y;
        dz.a[l] = r.d.z;
        enter.a[l] = on ? span.x : 0.0f;
        exit.a[l] = on ? span.y : 0.0f;
        nsegL.a[l] = on ? max((int)ceil((span.y - span.x) / P->march.step), 1) : 0;
        act.a[l] = on ? -1 : 0;
#ifdef GRADIENT_CACHE
        wo[l] = r.oWorld;
        wd[l] = r.dWorld;
        vx.a[l] = -r.dWorld.x;
        vy.a[l] = -r.dWorld.y;
        vz.a[l] = -r.dWorld.z;
#endif
#ifdef FOG
        /* Per lane: the fog's ray, and the fog in front of the volume (or all of it when the volume is missed). */
        fo[l] = r.oWorld;
        fd[l] = r.dWorld;
        fr[l] = fog_ray(&P->fog, r.oWorld, r.dWorld);
        float3 frgb = (float3)(0.0f);
        float fT = 1.0f;
        if (x < params.camera.width && y < params.camera.height && fr[l].span.y > fr[l].span.x)
            fog_only(&P->fog, fogMap, &fr[l], r.oWorld, r.dWorld, fr[l].span.x,
                     on ? fmin(fr[l].span.y, span.x) : fr[l].span.y, &frgb, &fT);
        fR.a[l] = frgb.x;
        fG.a[l] = frgb.y;
        fB.a[l] = frgb.z;
        fTT.a[l] = fT;
#endif
    }
    rp.ox = ox.v;
    rp.oy = oy.v;
    rp.oz = oz.v;
    rp.dx = dx.v;
    rp.dy = dy.v;
    rp.dz = dz.v;
    const float8 tEnter = enter.v, tExit = exit.v;
    const int8 nseg = nsegL.v;
    const float step = P->march.step;
    int8 active = act.v;
    int8 k = (int8)(0);
#ifdef FOG
    float8 cr = fR.v, cg = fG.v, cb = fB.v, T = fTT.v;
#else
    float8 cr = (float8)(0.0f), cg = (float8)(0.0f), cb = (float8)(0.0f), T = (float8)(1.0f);
#endif
#if PREINT != 0
    float8 sPrev = sample_packet(vol, &P->grid, &rp, tEnter);
#endif
#ifdef SKIPPING
    float8 cellExit = (float8)(-INFINITY);
#endif
    while (any(active)) {
        float8 t0 = tEnter + convert_float8(k) * step;
#ifdef SKIPPING
        const int8 need = active & (t0 >= cellExit);
        if (any(need)) {
            float8 exitT;
            LaneU cell;
            cell.v = macro_cell8(P, &rp, t0, &exitT);
            cellExit = select(cellExit, exitT, need);
            LaneI empty;
            _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) empty.a[l] = macroEmpty[cell.a[l]] ? -1 : 0;
            /* Segments with both ends in an empty cell add nothing: jump to the last one starting in it. */
            const int8 j = min(convert_int8(floor((exitT - tEnter) / step)), nseg);
            const int8 jump = need & empty.v & (j > k);
            if (any(jump)) {
#ifdef FOG
                fog_skip_packet(P, fogMap, fr, fo, fd, &enter, &nsegL, jump, j, t0, tExit, step, &cr, &cg,
                                &cb, &T);
#endif
                k = select(k, j, jump);
                active &= k < nseg;
                t0 = tEnter + convert_float8(k) * step;
#if PREINT != 0
                sPrev = select(sPrev, sample_packet(vol, &P->grid, &rp, t0), jump);
#endif
                if (!any(active)) break;
            }
        }
#endif
        const float8 t1 = select(fmin(t0 + step, tExit), tExit, k == nseg - 1);
        const float8 len = t1 - t0;
        LaneF er, eg, eb, ea;
#if PREINT == 0
        tf_packet(knots, P, sample_packet(vol, &P->grid, &rp, t0 + 0.5f * len), &er, &eg, &eb, &ea);
        const float8 a = 1.0f - exp(-ea.v * len);
#ifdef GRADIENT_CACHE
        if (any(active & (a > 0.0f)))
            shade_packet(gradCache, P, &rp, wo, wd, &vx, &vy, &vz, t0 + 0.5f * len, active & (a > 0.0f), 0,
                         &er, &eg, &eb, &ea SHADOW_ARGS);
#endif
        const float8 wr = T * a * er.v, wg = T * a * eg.v, wb = T * a * eb.v;
#else
        const float8 sNext = sample_packet(vol, &P->grid, &rp, t1);
        preint_packet(table, &P->tf, sPrev, sNext, len, &er.v, &eg.v, &eb.v, &ea.v);
#ifdef NAN_COLOR
        {
            /* Lanes whose segment has an end that is not finite: a constant segment of the NaN colour (the
               table lookup above stayed in bounds: its indices are clamped). */
            const int8 bad = ~(isfinite(sPrev) & isfinite(sNext));
            const float8 an = 1.0f - exp(-NAN_TAU * len);
            er.v = select(er.v, NAN_R * an, bad);
            eg.v = select(eg.v, NAN_G * an, bad);
            eb.v = select(eb.v, NAN_B * an, bad);
            ea.v = select(ea.v, an, bad);
        }
#endif
#ifdef GRADIENT_CACHE
        {
#ifdef NAN_COLOR
            const int8 lit = active & (ea.v > 0.0f) & isfinite(sPrev) & isfinite(sNext);
#else
            const int8 lit = active & (ea.v > 0.0f);
#endif
            if (any(lit))
                shade_packet(gradCache, P, &rp, wo, wd, &vx, &vy, &vz, t0 + 0.5f * len, lit, 1, &er, &eg, &eb,
                             &ea SHADOW_ARGS);
        }
#endif
        const float8 a = ea.v;
        const float8 wr = T * er.v, wg = T * eg.v, wb = T * eb.v;
        sPrev = sNext;
#endif
#ifdef FOG
        fog_segment_packet(P, fogMap, fr, fo, fd, active, t0, t1, &er, &eg, &eb, &ea, &cr, &cg, &cb, &T);
        (void)wr;
        (void)wg;
        (void)wb;
        (void)a;
#else
        cr = select(cr, cr + wr, active);
        cg = select(cg, cg + wg, active);
        cb = select(cb, cb + wb, active);
        T = select(T, T * (1.0f - a), active);
#endif
        k -= active; /* active lanes are -1 */
        active &= k < nseg;
#ifdef EARLY_TERMINATION
        active &= !(1.0f - T >= P->march.earlyTermination);
#endif
    }
#ifdef FOG
    fog_tail_packet(P, fogMap, fr, fo, fd, &nsegL, tExit, &cr, &cg, &cb, &T);
#endif
    store_packet(out, P, x0, y0, cr, cg, cb, T);
}
#endif
