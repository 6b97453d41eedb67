/* Transfer-function lookups for every renderer: the TF at a value (bit-identical to
   TransferFunction::sampleFloat on the host) and pre-integrated segments from the 2D or 3D table. */
#ifndef VOLCL_TF_LOOKUP_H
#define VOLCL_TF_LOOKUP_H

#include "camera_rays.h"

#pragma OPENCL FP_CONTRACT OFF

/* Index of the interval holding s: the last knot k with knots[k].s < s (0 when s <= knots[0].s). */
inline uint tf_find_interval(__global const VolclTfKnot* knots, uint count, float s) {
    uint lo = 0, hi = count; /* invariant: answer in [lo, hi) */
    while (hi - lo > 1) {
        uint mid = (lo + hi) / 2;
        if (knots[mid].s < s)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

#ifdef NAN_COLOR
/* The NaN colour (straight r, g, b, extinction tau) of a volume that holds NaN/Inf voxels: the host defines
   NAN_R, NAN_G, NAN_B, NAN_TAU only then, so finite volumes pay nothing (docs/rendering.md, "NaN and Inf"). */
#define NAN_RGBT ((float4)(NAN_R, NAN_G, NAN_B, NAN_TAU))
#endif

/* (r, g, b, tau) at data value s; with NAN_COLOR a sample that is not finite takes the NaN colour. */
inline float4 tf_sample(__global const VolclTfKnot* knots, uint count, float s) {
#ifdef NAN_COLOR
    if (!isfinite(s)) return NAN_RGBT;
#endif
    uint k = tf_find_interval(knots, count, s);
    __global const VolclTfKnot* kn = knots + k;
    /* Clamped so that s = +inf past the last knot (slope 0) gives its value, not inf * 0 = NaN. */
    float d = s > kn->s ? fmin(s - kn->s, FLT_MAX) : 0.0f;
    float4 v = (float4)(kn->value[0], kn->value[1], kn->value[2], kn->value[3]);
    float4 g = (float4)(kn->slope[0], kn->slope[1], kn->slope[2], kn->slope[3]);
    return v + d * g;
}

#ifdef TF_GRADIENT
/* A gradient TF (host/tf/TransferFunction.hpp, classify()): e = tf_sample() at value s, gm the sample's world
   gradient magnitude (data value per world unit). The value axis's extinction is scaled by the gradient
   opacity (knots after the value axis's, factor in channel 3), then each widget adds its extinction of its
   colour; the colour is the extinction-weighted mean. A gradient that is not finite (beside a NaN voxel)
   counts as beyond every widget and takes the gradient opacity's last value; a NaN colour stays. */
/* Whether a sample of value s (e = tf_sample() there) can take anything from the gradient terms: its value axis
   extinction is non-zero and a gradient opacity scales it, or s lies within a widget's reach along the value
   axis (a box's range; a Gaussian's centre +- 6 sigma, beyond which it adds under 1.6e-8 of its extinction).
   Elsewhere the sample is e and its gradient is not read: most samples of a CT (air) cost one fetch. */
inline bool tf_gradient_needed(__global const VolclTfKnot* knots, const VolclTfParams* T, float s, float4 e) {
    if (e.w > 0.0f && T->gradientKnotCount > 0) return true;
    __global const VolclTfWidget* w =
        (__global const VolclTfWidget*)(knots + T->knotCount + T->gradientKnotCount);
    for (uint i = 0; i < T->widgetCount; ++i) {
        if (w[i].shape != 1 ? s >= w[i].a[0] && s <= w[i].a[1] : fabs((s - w[i].a[0]) * w[i].a[1]) <= 6.0f)
            return true;
    }
    return false;
}

inline float4 tf_gradient(__global const VolclTfKnot* knots, const VolclTfParams* T, float s, float4 e,
                          float gm) {
#ifdef NAN_COLOR
    if (!isfinite(s)) return e;
#endif
    if (!isfinite(gm)) gm = INFINITY;
    float tau = e.w;
    if (T->gradientKnotCount > 0) {
        __global const VolclTfKnot* gk = knots + T->knotCount;
        __global const VolclTfKnot* kn = gk + tf_find_interval(gk, T->gradientKnotCount, gm);
        const float d = gm > kn->s ? fmin(gm - kn->s, FLT_MAX) : 0.0f;
        tau *= kn->value[3] + d * kn->slope[3];
    }
    float3 sum = e.xyz * tau;
    if (isfinite(s) && isfinite(gm)) {
        __global const VolclTfWidget* w =
            (__global const VolclTfWidget*)(knots + T->knotCount + T->gradientKnotCount);
        for (uint i = 0; i < T->widgetCount; ++i) {
            const float4 a = (float4)(w[i].a[0], w[i].a[1], w[i].a[2], w[i].a[3]);
            float t;
            if (w[i].shape == 1) {
                const float u = (s - a.x) * a.y, v = (gm - a.z) * a.w;
                t = w[i].rgbTau[3] * exp(-0.5f * (u * u + v * v));
            } else if (!(s >= a.x && s <= a.y && gm >= a.z && gm <= a.w)) {
                t = 0.0f;
            } else if (w[i].shape == 0) {
                t = w[i].rgbTau[3];
            } else {
                /* ParaView's box: its Gaussian of opacity (sigma 0.3 of the box), as extinction. */
                const float u = (s - 0.5f * (a.x + a.y)) / (VOLCL_PARAVIEW_BOX_SIGMA * (a.y - a.x)),
                            v = (gm - 0.5f * (a.z + a.w)) / (VOLCL_PARAVIEW_BOX_SIGMA * (a.w - a.z));
                const float op = fmin(w[i].rgbTau[3] * exp(-0.5f * (u * u + v * v)), 1.0f);
                t = fmin(-log1p(-op), VOLCL_MAX_IMPORTED_EXTINCTION) * w[i].invUnitDistance;
            }
            sum += (float3)(w[i].rgbTau[0], w[i].rgbTau[1], w[i].rgbTau[2]) * t;
            tau += t;
        }
    }
    return tau > 0.0f ? (float4)(sum / tau, tau) : (float4)(e.xyz, 0.0f);
}
#endif

/* Pre-integration (PREINT 2: 2D table at the fixed length T->tableMaxLength; PREINT 3: 3D table over
   segment lengths). The table's slices are tableSize x tableSize nodes over [domainLo, domainHi], front
   value fastest-but-one, back value fastest. */
#if PREINT == 2 || PREINT == 3
/* Table value at fractional node coordinates (front u, back v) of slice k: bilinear. */
inline float4 table_bilinear(__global const float4* table, uint n, uint k, float u, float v) {
    const float hi = (float)(n - 1);
    u = clamp(u, 0.0f, hi);
    v = clamp(v, 0.0f, hi);
    const uint i0 = min((uint)u, n - 2), j0 = min((uint)v, n - 2);
    const float fu = u - (float)i0, fv = v - (float)j0;
    __global const float4* row0 = table + ((size_t)k * n + i0) * n;
    __global const float4* row1 = row0 + n;
    const float4 a = row0[j0] + fv * (row0[j0 + 1] - row0[j0]);
    const float4 b = row1[j0] + fv * (row1[j0 + 1] - row1[j0]);
    return a + fu * (b - a);
}

/* Associated (rgb, alpha) of a segment with linear scalar from sf to sb and length len. */
inline float4 preint_segment(__global const float4* table, const VolclTfParams* T, float sf, float sb,
                             float len) {
    const float scale = (float)(T->tableSize - 1) / (T->domainHi - T->domainLo);
    const float u = (sf - T->domainLo) * scale, v = (sb - T->domainLo) * scale;
#if PREINT == 2
    float4 e = table_bilinear(table, T->tableSize, 0, u, v);
    const float tableLen = T->tableMaxLength;
#else
    /* Slices hold l_k = (k + 1) D / L; below l_0 interpolate toward the empty segment. */
    const float kf = len * (float)T->tableLengths / T->tableMaxLength - 1.0f;
    float4 e;
    float tableLen = len;
    if (kf <= 0.0f) {
        e = table_bilinear(table, T->tableSize, 0, u, v) * fmax(kf + 1.0f, 0.0f);
    } else if (kf >= (float)(T->tableLengths - 1)) {
        e = table_bilinear(table, T->tableSize, T->tableLengths - 1, u, v);
        tableLen = T->tableMaxLength;
    } else {
        const uint k0 = (uint)kf;
        const float fk = kf - (float)k0;
        const float4 a = table_bilinear(table, T->tableSize, k0, u, v);
        e = a + fk * (table_bilinear(table, T->tableSize, k0 + 1, u, v) - a);
    }
#endif
    if (len != tableLen) {
        /* Other length: exact for a constant scalar (alpha from optical depth, colour in proportion). */
        const float a = clamp(e.w, 0.0f, 1.0f);
        const float an = a < 1.0f ? 1.0f - pow(1.0f - a, len / tableLen) : 1.0f;
        const float3 rgb = a > 0.0f ? e.xyz * (an / a) : e.xyz * (len / tableLen);
        e = (float4)(rgb, an);
    }
    return e;
}

/* Bilinear table value of slice k at node cell (i0, j0) with fractions (fu, fv): table_bilinear's arithmetic
   after its index computation. */
PACKET_INLINE float4 table_cell(__global const float4* table, uint n, uint k, uint i0, uint j0, float fu,
                                float fv) {
    __global const float4* row0 = table + ((size_t)k * n + i0) * n;
    __global const float4* row1 = row0 + n;
    const float4 a = row0[j0] + fv * (row0[j0 + 1] - row0[j0]);
    const float4 b = row1[j0] + fv * (row1[j0 + 1] - row1[j0]);
    return a + fu * (b - a);
}

/* preint_segment for a packet: index arithmetic and the length correction in float8, the four table reads
   per lane. Returns associated (r, g, b, alpha) per lane. */
PACKET_INLINE void preint_packet(__global const float4* table, const VolclTfParams* T, float8 sf, float8 sb,
                                 float8 len, float8* outR, float8* outG, float8* outB, float8* outA) {
    const uint n = T->tableSize;
    const float scale = (float)(n - 1) / (T->domainHi - T->domainLo);
    const float hi = (float)(n - 1);
    const float8 u = clamp((sf - T->domainLo) * scale, 0.0f, hi),
                 v = clamp((sb - T->domainLo) * scale, 0.0f, hi);
    LaneU i0, j0;
    i0.v = min(convert_uint8(u), (uint8)(n - 2)); /* vector bounds, as in grid_sample.h */
    j0.v = min(convert_uint8(v), (uint8)(n - 2));
    LaneF fu, fv;
    fu.v = u - convert_float8(i0.v);
    fv.v = v - convert_float8(j0.v);
    LaneF er, eg, eb, ea;
#if PREINT == 2
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const float4 e = table_cell(table, n, 0, i0.a[l], j0.a[l], fu.a[l], fv.a[l]);
        er.a[l] = e.x;
        eg.a[l] = e.y;
        eb.a[l] = e.z;
        ea.a[l] = e.w;
    }
    const float8 tableLen = (float8)(T->tableMaxLength);
#else
    /* Slices hold l_k = (k + 1) D / L; below l_0 interpolate toward the empty segment. */
    const uint L = T->tableLengths;
    LaneF kf;
    kf.v = len * (float)L / T->tableMaxLength - 1.0f;
    _Pragma("unroll") for (int l = 0; l < RAY_LANES; ++l) {
        const float k = kf.a[l];
        float4 e;
        if (k <= 0.0f) {
            e = table_cell(table, n, 0, i0.a[l], j0.a[l], fu.a[l], fv.a[l]) * fmax(k + 1.0f, 0.0f);
        } else if (k >= (float)(L - 1)) {
            e = table_cell(table, n, L - 1, i0.a[l], j0.a[l], fu.a[l], fv.a[l]);
        } else {
            const uint k0 = (uint)k;
            const float fk = k - (float)k0;
            const float4 a = table_cell(table, n, k0, i0.a[l], j0.a[l], fu.a[l], fv.a[l]);
            e = a + fk * (table_cell(table, n, k0 + 1, i0.a[l], j0.a[l], fu.a[l], fv.a[l]) - a);
        }
        er.a[l] = e.x;
        eg.a[l] = e.y;
        eb.a[l] = e.z;
        ea.a[l] = e.w;
    }
    const float8 tableLen =
        select(len, (float8)(T->tableMaxLength), (kf.v > 0.0f) & (kf.v >= (float)(L - 1)));
#endif
    const int8 other = len != tableLen;
    if (any(other)) {
        /* Other length: exact for a constant scalar (alpha from optical depth, colour in proportion). */
        const float8 a = clamp(ea.v, 0.0f, 1.0f);
        const float8 an = select((float8)(1.0f), 1.0f - pow(1.0f - a, len / tableLen), a < 1.0f);
        const float8 ratio = select(len / tableLen, an / a, a > 0.0f);
        er.v = select(er.v, er.v * ratio, other);
        eg.v = select(eg.v, eg.v * ratio, other);
        eb.v = select(eb.v, eb.v * ratio, other);
        ea.v = select(ea.v, an, other);
    }
    *outR = er.v;
    *outG = eg.v;
    *outB = eb.v;
    *outA = ea.v;
}
#endif

#endif
