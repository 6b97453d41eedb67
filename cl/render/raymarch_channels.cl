/* Multi-channel ray marching: up to 4 scalar channels on one grid, each with its own voxel type and TF.
   Built with CHANNELS (1..4), CH_TYPE0..CH_TYPE3 (each channel's stored type), and BLEND: 0 additive (the
   extinctions and emissions of the channels summed per sample), 1 maximum (a MIP per channel, the TF colours
   of the maxima added), 2 direct colour (channels 0..2 are r, g, b; opacity from channel 3 or luminance
   through channel 0's TF). The scalar kernels never include this file. */
#include "channels_shared.h"
#include "common/camera_rays.h"
#include "common/tf_lookup.h"

#pragma OPENCL FP_CONTRACT OFF

/* CH_TYPE<c>: 1 uint8, 2 uint16, 3 int16, else float32 (the codes of VOXEL_TYPE in grid_sample.h). */
#define CHANNEL_TYPE(code) CHANNEL_TYPE_I(code)
#define CHANNEL_TYPE_I(code) CHANNEL_TYPE_##code
#define CHANNEL_TYPE_0 float
#define CHANNEL_TYPE_1 uchar
#define CHANNEL_TYPE_2 ushort
#define CHANNEL_TYPE_3 short
#define CH_T0 CHANNEL_TYPE(CH_TYPE0)
#define CH_T1 CHANNEL_TYPE(CH_TYPE1)
#define CH_T2 CHANNEL_TYPE(CH_TYPE2)
#define CH_T3 CHANNEL_TYPE(CH_TYPE3)

/* Trilinear sample at voxel coordinates p (clamped): the arithmetic of grid_sample.h's sample_volume, so a
   non-finite corner makes the sample non-finite even at weight 0 (the NaN rule). Buffers carry a spare voxel. */
#define DEFINE_CHANNEL_SAMPLE(NAME, T)                                                                       \
    inline float NAME(__global const T* vol, const VolclGridParams* G, float3 p) {                           \
        const int3 hiI = (int3)((int)G->dims[0] - 1, (int)G->dims[1] - 1, (int)G->dims[2] - 1);              \
        p = clamp(p, (float3)(0.0f), convert_float3(hiI));                                                   \
        int3 i0 = convert_int3(floor(p));                                                                    \
        i0 = min(i0, max(hiI - 1, (int3)(0)));                                                               \
        const int3 i1 = min(i0 + 1, hiI);                                                                    \
        const float3 f = p - convert_float3(i0);                                                             \
        const uint nx = G->dims[0], nxy = G->dims[0] * G->dims[1];                                           \
        const uint z0 = (uint)i0.z * nxy, z1 = (uint)i1.z * nxy, y0 = (uint)i0.y * nx, y1 = (uint)i1.y * nx; \
        const float2 a00 = convert_float2(vload2(0, vol + z0 + y0 + i0.x));                                  \
        const float2 a10 = convert_float2(vload2(0, vol + z0 + y1 + i0.x));                                  \
        const float2 a01 = convert_float2(vload2(0, vol + z1 + y0 + i0.x));                                  \
        const float2 a11 = convert_float2(vload2(0, vol + z1 + y1 + i0.x));                                  \
        const float c00 = a00.x + f.x * (a00.y - a00.x), c10 = a10.x + f.x * (a10.y - a10.x);                \
        const float c01 = a01.x + f.x * (a01.y - a01.x), c11 = a11.x + f.x * (a11.y - a11.x);                \
        const float c0 = c00 + f.y * (c10 - c00), c1 = c01 + f.y * (c11 - c01);                              \
        return c0 + f.z * (c1 - c0);                                                                         \
    }

DEFINE_CHANNEL_SAMPLE(sample_ch0, CH_T0)
DEFINE_CHANNEL_SAMPLE(sample_ch1, CH_T1)
DEFINE_CHANNEL_SAMPLE(sample_ch2, CH_T2)
DEFINE_CHANNEL_SAMPLE(sample_ch3, CH_T3)

/* The CHANNELS samples at voxel coordinates p. */
inline void sample_channels(__global const CH_T0* c0, __global const CH_T1* c1, __global const CH_T2* c2,
                            __global const CH_T3* c3, const VolclGridParams* G, float3 p, float s[4]) {
    s[0] = sample_ch0(c0, G, p);
    s[1] = CHANNELS > 1 ? sample_ch1(c1, G, p) : 0.0f;
    s[2] = CHANNELS > 2 ? sample_ch2(c2, G, p) : 0.0f;
    s[3] = CHANNELS > 3 ? sample_ch3(c3, G, p) : 0.0f;
}

/* (r, g, b, tau) of channel c at value s: its TF, or the NaN colour for a non-finite sample. */
inline float4 channel_classify(__global const VolclTfKnot* knots, const VolclChannelParams* K, int c,
                               float s) {
    if (!isfinite(s)) return (float4)(K->nanRgbt[0], K->nanRgbt[1], K->nanRgbt[2], K->nanRgbt[3]);
    return tf_sample(knots + K->knotStart[c], K->knotCount[c], s);
}

__kernel void raymarch_channels(__global const CH_T0* ch0, __global const CH_T1* ch1,
                                __global const CH_T2* ch2, __global const CH_T3* ch3,
                                __global const VolclTfKnot* knots, const VolclChannelRenderParams params,
                                __global float4* out) {
    const uint x = get_global_id(0), y = get_global_id(1);
    if (x >= params.camera.width || y >= params.camera.height) return;
    const VolclChannelRenderParams* P = &params;
    const VolclChannelParams* K = &P->channels;
    const WorldRay w = camera_ray_world(&P->camera, x, y);
    const float3 inv = v3(P->grid.invSpacing);
    const float3 o = (w.o - v3(P->grid.origin)) * inv, d = w.d * inv;
    const float3 hi = (float3)(P->grid.dims[0] - 1, P->grid.dims[1] - 1, P->grid.dims[2] - 1);
    /* The ray interval inside the box [0, n - 1] (voxel coordinates), then the clip planes (world). */
    float2 span = (float2)(0.0f, INFINITY);
    const float oa[3] = {o.x, o.y, o.z}, da[3] = {d.x, d.y, d.z}, ha[3] = {hi.x, hi.y, hi.z};
    for (int a = 0; a < 3; ++a) {
        if (da[a] == 0.0f) {
            if (oa[a] < 0.0f || oa[a] > ha[a]) span = (float2)(1.0f, 0.0f);
        } else {
            const float t1 = (0.0f - oa[a]) / da[a], t2 = (ha[a] - oa[a]) / da[a];
            span.x = fmax(span.x, fmin(t1, t2));
            span.y = fmin(span.y, fmax(t1, t2));
        }
    }
    clip_planes(&P->clip, w.o, w.d, &span);
    float4 result = (float4)(0.0f);
    if (span.y > span.x) {
        const float step = P->march.step;
        const int nseg = max((int)ceil((span.y - span.x) / step), 1);
#if BLEND == 1
        float best[4] = {-INFINITY, -INFINITY, -INFINITY, -INFINITY};
#else
        float cr = 0.0f, cg = 0.0f, cb = 0.0f, T = 1.0f;
#endif
        for (int k = 0; k < nseg; ++k) {
            const float t0 = span.x + (float)k * step;
            const float t1 = k == nseg - 1 ? span.y : fmin(t0 + step, span.y);
            const float len = t1 - t0;
            float s[4];
            sample_channels(ch0, ch1, ch2, ch3, &P->grid, o + (t0 + 0.5f * len) * d, s);
#if BLEND == 1
            for (int c = 0; c < CHANNELS; ++c)
                if (isfinite(s[c])) best[c] = fmax(best[c], s[c]); /* MIP skips non-finite samples */
#else
#if BLEND == 2
            float4 e;
            if (!(isfinite(s[0]) && isfinite(s[1]) && isfinite(s[2]) && isfinite(s[3]))) {
                e = channel_classify(knots, K, 0, NAN);
            } else {
                const float r = s[0] * K->colorScale[0], g = s[1] * K->colorScale[1],
                            b = s[2] * K->colorScale[2];
                const float opacity =
                    CHANNELS > 3 ? s[3] * K->colorScale[3] : 0.2126f * r + 0.7152f * g + 0.0722f * b;
                e = (float4)(r, g, b, tf_sample(knots, K->knotCount[0], opacity).w);
            }
            const float sigma = e.w;
            const float er = e.x * sigma, eg = e.y * sigma, eb = e.z * sigma;
#else
            float sigma = 0.0f, er = 0.0f, eg = 0.0f, eb = 0.0f;
            for (int c = 0; c < CHANNELS; ++c) {
                if (!K->visible[c]) continue;
                const float4 e = channel_classify(knots, K, c, s[c]);
                sigma += e.w;
                er += e.w * e.x;
                eg += e.w * e.y;
                eb += e.w * e.z;
            }
#endif
            if (sigma > 0.0f) {
                /* Emission weighted by each channel's share of the summed extinction. */
                const float a = 1.0f - exp(-sigma * len), f = T * a / sigma;
                cr += f * er;
                cg += f * eg;
                cb += f * eb;
                T *= 1.0f - a;
            }
            if (1.0f - T >= P->march.earlyTermination) break;
#endif
        }
#if BLEND == 1
        float keep = 1.0f;
        for (int c = 0; c < CHANNELS; ++c) {
            if (!K->visible[c] || best[c] == -INFINITY) continue;
            const float4 e = channel_classify(knots, K, c, best[c]);
            const float a = 1.0f - exp(-e.w); /* the maximum's opacity over one world unit */
            result.x += a * e.x;
            result.y += a * e.y;
            result.z += a * e.z;
            keep *= 1.0f - a;
        }
        result.w = 1.0f - keep;
#else
        result = (float4)(cr, cg, cb, 1.0f - T);
#endif
    }
    out[(size_t)y * params.camera.width + x] = result;
}
