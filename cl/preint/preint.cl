/* Pre-integration table kernels (the table layout of docs/contract.md): exact segment integrals, Weiler-style length recursion,
   Engel's integral functions, Roettger's linear-in-length 2D table and the 2D+1D chromaticity polynomial. */
#include "volcl_shared.h"

#pragma OPENCL FP_CONTRACT OFF

/* REAL is the arithmetic precision (float or double, -DUSE_DOUBLE). LANES table lengths are processed as one
   OpenCL vector (1, 2, 4, 8 or 16) and BLOCKS such vectors per work-item, so one (s_f, s_b) pair walks its
   transfer-function pieces once for LANES * BLOCKS lengths. */
#ifdef USE_DOUBLE
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#define REAL double
#define REAL_C(x) x
#else
#define REAL float
#define REAL_C(x) x##f
#endif

#ifndef LANES
#define LANES 1
#endif
#ifndef BLOCKS
#define BLOCKS 1
#endif

#define CAT_(a, b) a##b
#define CAT(a, b) CAT_(a, b)
#if LANES == 1
typedef REAL VEC;
#define VLOAD(p) ((VEC)(p)[0])
#define VSTORE(v, p) ((p)[0] = (v))
#else
typedef CAT(REAL, LANES) VEC;
#define VLOAD(p) CAT(vload, LANES)(0, p)
#define VSTORE(v, p) CAT(vstore, LANES)(v, 0, p)
#endif
#define CHUNK (LANES * BLOCKS)

/* Colour integration stops once every length of the chunk has transmittance below exp(-PREINT_CUTOFF):
   the rest of the segment can add at most maxColor * exp(-24) = 4e-11 * maxColor to any entry. */
#define PREINT_CUTOFF REAL_C(24.0)

/* 1 - exp(-x) for x >= 0 without the scalar expm1 (measured far slower than exp on PoCL 3.1): a series where
   1 - exp(-x) would cancel, else the direct form (relative error below 1e-7 in float either way). */
inline REAL preint_one_minus_exp(REAL x) {
    return x < REAL_C(0.01) ? x * (REAL_C(1.0) - x * (REAL_C(0.5) - x * (REAL_C(1.0) / REAL_C(6.0))))
                            : REAL_C(1.0) - exp(-x);
}
#if LANES > 1
inline VEC preint_one_minus_exp_v(VEC x) {
    VEC series = x * (REAL_C(1.0) - x * (REAL_C(0.5) - x * (REAL_C(1.0) / REAL_C(6.0))));
    return x < (VEC)(REAL_C(0.01)) ? series : REAL_C(1.0) - exp(-x);
}
#else
#define preint_one_minus_exp_v preint_one_minus_exp
#endif

/* One linear piece of the transfer function along a segment, in segment coordinates. */
typedef struct {
    REAL h; /* width as a fraction of the segment */
    REAL tauA, tauB;
    REAL cA[3], cB[3];
} PreintPiece;

/* Transfer-function value (r, g, b, tau) at s using the formula of knot interval k (-1: below the first
 * knot). */
inline void preint_eval(__global const VolclTfKnot* knots, int k, REAL s, REAL out[4]) {
    int kk = k < 0 ? 0 : k;
    REAL d = k < 0 ? REAL_C(0.0) : s - (REAL)knots[kk].s;
    for (int c = 0; c < 4; ++c)
        out[c] = (REAL)knots[kk].value[c] + d * (REAL)knots[kk].slope[c];
}

/* Walks the knot intervals a segment from sf to sb (sf != sb) passes. State: current s and interval k.
   Returns 0 when the segment is finished, else fills `piece`. Upwards the interval starting at the last knot
   <= s is entered; downwards the interval (S_k, S_k+1] holding s, so steps take the value on the side being
   entered. */
typedef struct {
    REAL s, sb, invSpan;
    int k, up;
} PreintWalk;

inline PreintWalk preint_walk_begin(__global const VolclTfKnot* knots, uint count, REAL sf, REAL sb) {
    PreintWalk w;
    w.s = sf;
    w.sb = sb;
    w.invSpan = REAL_C(1.0) / (sb - sf);
    w.up = sb > sf;
    int k = -1;
    for (uint i = 0; i < count; ++i) {
        REAL si = (REAL)knots[i].s;
        if (w.up ? si <= sf : si < sf) k = (int)i;
    }
    w.k = k;
    return w;
}

inline int preint_walk_next(__global const VolclTfKnot* knots, uint count, PreintWalk* w, PreintPiece* p) {
    if (w->up ? w->s >= w->sb : w->s <= w->sb) return 0;
    REAL se;
    if (w->up) {
        se = (w->k + 1 < (int)count) ? fmin((REAL)knots[w->k + 1].s, w->sb) : w->sb;
    } else {
        se = (w->k >= 0) ? fmax((REAL)knots[w->k].s, w->sb) : w->sb;
    }
    REAL a[4], b[4];
    int k = w->k < (int)count ? w->k : (int)count - 1;
    preint_eval(knots, k, w->s, a);
    preint_eval(knots, k, se, b);
    if (w->k == (int)count - 1) { /* above the last knot the value is constant */
        for (int c = 0; c < 4; ++c)
            b[c] = a[c];
    }
    p->h = (se - w->s) * w->invSpan;
    p->tauA = fmax(a[3], REAL_C(0.0));
    p->tauB = fmax(b[3], REAL_C(0.0));
    for (int c = 0; c < 3; ++c) {
        p->cA[c] = a[c];
        p->cB[c] = b[c];
    }
    w->s = se;
    w->k += w->up ? 1 : -1;
    return 1;
}

/* Value at s exactly (the earlier knot's value at a step), for the s_f = s_b diagonal. */
inline void preint_value_at(__global const VolclTfKnot* knots, uint count, REAL s, REAL out[4]) {
    int k = -1;
    for (uint i = 0; i < count; ++i)
        if ((REAL)knots[i].s < s) k = (int)i;
    preint_eval(knots, k, s, out);
    out[3] = fmax(out[3], REAL_C(0.0));
}

/* Exact segment integrals for CHUNK lengths per work-item.
   Integration by parts turns rgb = int c dT' (T' = -dT) into, per linear piece of width h,
     c_a T_a - c_b T_b + (c_b - c_a) * mean(T over the piece),
   so only the mean transmittance needs quadrature. Within a piece tau is linear, the optical depth is a
   closed-form quadratic, and the mean is taken with 3-point Gauss-Legendre on sub-pieces whose optical depth
   stays below maxSubstepDepth at every length that still matters. Alpha uses the closed-form total depth.
   gid0 = back index (x in the table), gid1 = front index, gid2 = chunk of lengths.
   `lengths` holds lengthCount values padded to a multiple of CHUNK; `uniformStep` > 0 means lengths[j] =
   lengths[0] + j * uniformStep, which lets later blocks reuse the first block's exponentials. */
__kernel void preint_exact(__global const VolclTfKnot* knots, uint knotCount, uint n, REAL lo, REAL hi,
                           __global const REAL* lengths, uint lengthCount, REAL uniformStep, REAL maxColor,
                           REAL maxSubstepDepth, __global float4* out) {
    uint ib = get_global_id(0), jf = get_global_id(1), chunk = get_global_id(2);
    if (ib >= n || jf >= n || chunk * CHUNK >= lengthCount) return;
    REAL ds = (hi - lo) / (REAL)(n - 1);
    REAL sf = jf == n - 1 ? hi : lo + (REAL)jf * ds;
    REAL sb = ib == n - 1 ? hi : lo + (REAL)ib * ds;

    __global const REAL* chunkLengths = lengths + chunk * CHUNK;
    uint valid = min((uint)CHUNK, lengthCount - chunk * CHUNK);
    REAL lmin = chunkLengths[0], lmax = chunkLengths[valid - 1];

    VEC len[BLOCKS], accR[BLOCKS], accG[BLOCKS], accB[BLOCKS], tCur[BLOCKS];
    for (int b = 0; b < BLOCKS; ++b) {
        len[b] = VLOAD(chunkLengths + b * LANES);
        accR[b] = accG[b] = accB[b] = (VEC)(REAL_C(0.0));
        tCur[b] = (VEC)(REAL_C(1.0));
    }
    REAL depth = REAL_C(0.0); /* optical depth per unit length from the front to the current position */

    if (ib == jf) {
        REAL v[4];
        preint_value_at(knots, knotCount, sf, v);
        depth = v[3];
        for (int b = 0; b < BLOCKS; ++b) {
            VEC a = preint_one_minus_exp_v(len[b] * depth);
            accR[b] = v[0] * a;
            accG[b] = v[1] * a;
            accB[b] = v[2] * a;
        }
    } else {
        const REAL glU0 = REAL_C(0.1127016653792583), glU1 = REAL_C(0.5), glU2 = REAL_C(0.8872983346207417);
        const REAL glW0 = REAL_C(0.2777777777777778), glW1 = REAL_C(0.4444444444444444);
        /* With uniform spacing, block b's lengths are block 0's plus b * LANES * uniformStep. */
        REAL blockShift = uniformStep * (REAL)LANES;
        int colourDone = 0;
        PreintWalk walk = preint_walk_begin(knots, knotCount, sf, sb);
        PreintPiece p;
        while (preint_walk_next(knots, knotCount, &walk, &p)) {
            REAL pieceDepth = p.h * REAL_C(0.5) * (p.tauA + p.tauB);
            if (colourDone) {
                depth += pieceDepth;
                continue;
            }
            REAL v = REAL_C(0.0);
            REAL slopeAbs = fabs(p.tauB - p.tauA) * p.h; /* |d rate / dv| of the unit depth */
            do {
                if (lmin * depth > PREINT_CUTOFF) {
                    colourDone = 1;
                    break;
                }
                /* Longest length that still matters at this depth, then the widest sub-piece it allows. */
                REAL lEff = depth > REAL_C(0.0) ? fmin(lmax, PREINT_CUTOFF / depth) : lmax;
                /* Sub-piece width from the local rate: depth(dv) = a dv + b dv^2 / 2 <= maxSubstepDepth. A bound
                   from the piece's largest rate instead made the count grow like sqrt(length) where tau rises
                   from zero. Each sub-piece adds maxSubstepDepth to lEff * depth, so a piece takes at most
                   (PREINT_CUTOFF / maxSubstepDepth) (1 + ln(lmax / lmin)) of them whatever the lengths. The
                   floor keeps v moving in float; a sub-piece that narrow is saturated, and its colour term is
                   exact to first order (the colour changes by (cB - cA) * 1.2e-7 across it). */
                REAL rateV = (p.tauA + (p.tauB - p.tauA) * v) * p.h;
                REAL qa = lEff * rateV, qb = lEff * slopeAbs;
                REAL dv = (qa > REAL_C(0.0) || qb > REAL_C(0.0))
                              ? REAL_C(2.0) * maxSubstepDepth /
                                    (qa + sqrt(qa * qa + REAL_C(2.0) * qb * maxSubstepDepth))
                              : REAL_C(1.0);
                dv = fmax(dv, REAL_C(1.2e-7));
                REAL v1 = (dv >= REAL_C(1.0) - v) ? REAL_C(1.0) : v + dv;
                REAL hs = (v1 - v) * p.h;
                REAL ta = p.tauA + (p.tauB - p.tauA) * v, tb = p.tauA + (p.tauB - p.tauA) * v1;
                REAL dt = tb - ta;
                REAL x0 = depth + hs * glU0 * (ta + REAL_C(0.5) * dt * glU0);
                REAL x1 = depth + hs * glU1 * (ta + REAL_C(0.5) * dt * glU1);
                REAL x2 = depth + hs * glU2 * (ta + REAL_C(0.5) * dt * glU2);
                REAL xe = depth + hs * REAL_C(0.5) * (ta + tb);
                REAL ca[3], dc[3];
                for (int c = 0; c < 3; ++c) {
                    ca[c] = p.cA[c] + (p.cB[c] - p.cA[c]) * v;
                    dc[c] = (p.cB[c] - p.cA[c]) * (v1 - v);
                }
                VEC e0 = exp(-len[0] * x0), e1 = exp(-len[0] * x1), e2 = exp(-len[0] * x2),
                    ee = exp(-len[0] * xe);
                REAL f0 = 0, f1 = 0, f2 = 0, fe = 0;
                if (BLOCKS > 1) /* compile-time constant: kept out of the && so the compiler does not warn */
                    if (uniformStep > REAL_C(0.0)) {
                        f0 = exp(-blockShift * x0);
                        f1 = exp(-blockShift * x1);
                        f2 = exp(-blockShift * x2);
                        fe = exp(-blockShift * xe);
                    }
                for (int b = 0; b < BLOCKS; ++b) {
                    if (b > 0) {
                        if (uniformStep > REAL_C(0.0)) {
                            e0 *= f0;
                            e1 *= f1;
                            e2 *= f2;
                            ee *= fe;
                        } else {
                            e0 = exp(-len[b] * x0);
                            e1 = exp(-len[b] * x1);
                            e2 = exp(-len[b] * x2);
                            ee = exp(-len[b] * xe);
                        }
                    }
                    /* c_a T_a - c_b T_b + dc * mean T, with c_b = c_a + dc (explicit mad: FP_CONTRACT is off)
                     */
                    VEC meanT = mad((VEC)(glW0), e0 + e2, glW1 * e1);
                    VEC w = tCur[b] - ee, m = meanT - ee;
                    accR[b] = mad((VEC)(ca[0]), w, mad((VEC)(dc[0]), m, accR[b]));
                    accG[b] = mad((VEC)(ca[1]), w, mad((VEC)(dc[1]), m, accG[b]));
                    accB[b] = mad((VEC)(ca[2]), w, mad((VEC)(dc[2]), m, accB[b]));
                    tCur[b] = ee;
                }
                depth = xe;
                v = v1;
            } while (v < REAL_C(1.0));
            if (colourDone)
                depth += (REAL_C(1.0) - v) * p.h * REAL_C(0.5) * (p.tauA + (p.tauB - p.tauA) * v + p.tauB);
        }
    }

    for (int b = 0; b < BLOCKS; ++b) {
        REAL r[LANES], g[LANES], bl[LANES], a[LANES];
        VEC alpha = preint_one_minus_exp_v(len[b] * depth);
        VEC bound = alpha * maxColor;
        VSTORE(clamp(accR[b], (VEC)(REAL_C(0.0)), bound), r);
        VSTORE(clamp(accG[b], (VEC)(REAL_C(0.0)), bound), g);
        VSTORE(clamp(accB[b], (VEC)(REAL_C(0.0)), bound), bl);
        VSTORE(alpha, a);
        for (int l = 0; l < LANES; ++l) {
            uint j = chunk * CHUNK + (uint)(b * LANES + l);
            if (j < lengthCount)
                out[((size_t)j * n + jf) * n + ib] =
                    (float4)((float)r[l], (float)g[l], (float)bl[l], (float)a[l]);
        }
    }
}

#if LANES == 16
/* The largest lane, as a tree of scalar fmax (the same value in any order). Not fmax(v.lo, v.hi): Oclgrind
   reports a part of a 16-lane vector passed to a builtin as uninitialised (tests/oclgrind/fmax_half_vectors.cl),
   more than a thousand false reports per table. */
inline REAL preint_hmax(VEC v) {
    return fmax(fmax(fmax(fmax(v.s0, v.s1), fmax(v.s2, v.s3)), fmax(fmax(v.s4, v.s5), fmax(v.s6, v.s7))),
                fmax(fmax(fmax(v.s8, v.s9), fmax(v.sa, v.sb)), fmax(fmax(v.sc, v.sd), fmax(v.se, v.sf))));
}

/* One direction of the 2D walk for 16 segments that share s_f (lanes = 16 consecutive back nodes). `dir` = +1
   walks upwards for the lanes with s_b > s_f, -1 downwards for s_b < s_f; other lanes see zero-width pieces.
   The knot intervals are common to all lanes (they start at the same s_f), so the loop over them is uniform;
   within a piece every lane splits the part that still matters (optical depth below PREINT_CUTOFF) into the
   same number of Gauss-Legendre sub-pieces, enough for the lane that needs most. */
inline void preint_row_pass(__global const VolclTfKnot* knots, uint count, REAL sf, VEC sb, REAL len, int dir,
                            REAL maxSubstepDepth, VEC* depth, VEC* tCur, VEC* accR, VEC* accG, VEC* accB) {
    const REAL glU0 = REAL_C(0.1127016653792583), glU1 = REAL_C(0.5), glU2 = REAL_C(0.8872983346207417);
    const REAL glW0 = REAL_C(0.2777777777777778), glW1 = REAL_C(0.4444444444444444);
    VEC span = dir > 0 ? sb - sf : sf - sb;
    VEC invSpan = span > (VEC)(REAL_C(0.0)) ? REAL_C(1.0) / span : (VEC)(REAL_C(0.0));
    REAL far = dir > 0 ? preint_hmax(sb) : -preint_hmax(-sb);
    if (dir > 0 ? far <= sf : far >= sf) return;
    int k = -1;
    for (uint i = 0; i < count; ++i) {
        REAL si = (REAL)knots[i].s;
        if (dir > 0 ? si <= sf : si < sf) k = (int)i;
    }
    REAL s = sf;
    while (dir > 0 ? s < far : s > far) {
        REAL edge;
        if (dir > 0)
            edge = (k + 1 < (int)count) ? (REAL)knots[k + 1].s : far;
        else
            edge = (k >= 0) ? (REAL)knots[k].s : far;
        edge = dir > 0 ? fmin(edge, far) : fmax(edge, far);
        VEC se = dir > 0 ? fmax(fmin((VEC)(edge), sb), (VEC)(s)) : fmin(fmax((VEC)(edge), sb), (VEC)(s));
        REAL a[4];
        int kk = k < (int)count ? k : (int)count - 1;
        preint_eval(knots, kk, s, a);
        int kc = kk < 0 ? 0 : kk;
        REAL slope[4];
        for (int c = 0; c < 4; ++c)
            slope[c] = (k < 0 || k == (int)count - 1) ? REAL_C(0.0) : (REAL)knots[kc].slope[c];
        VEC ds = se - s; /* signed s distance of each lane's piece */
        VEC h = fabs(ds) * invSpan;
        REAL tauA = fmax(a[3], REAL_C(0.0));
        VEC tauB = fmax(a[3] + ds * slope[3], (VEC)(REAL_C(0.0)));
        VEC P = len * h * tauA, Q = len * h * tauB;
        VEC X = REAL_C(0.5) * (P + Q);
        VEC rest = PREINT_CUTOFF - len * (*depth);
        /* Fraction of the piece before the optical depth reaches the cutoff (root of P v + (Q-P) v^2 / 2 =
         * rest). */
        VEC disc = sqrt(fmax(P * P + REAL_C(2.0) * (Q - P) * rest, (VEC)(REAL_C(0.0))));
        VEC vEnd = X <= rest ? (VEC)(REAL_C(1.0)) : REAL_C(2.0) * rest / (P + disc);
        vEnd = rest > (VEC)(REAL_C(0.0)) ? clamp(vEnd, (VEC)(REAL_C(0.0)), (VEC)(REAL_C(1.0)))
                                         : (VEC)(REAL_C(0.0));
        VEC rateEnd = fmax(P, P + (Q - P) * vEnd);
        /* rateEnd * vEnd <= 2 * (depth up to vEnd) <= 2 * PREINT_CUTOFF, so the count is bounded by the cutoff,
           not by the length; fmin also maps a NaN from an overflowed product to the bound. */
        REAL need = preint_hmax(rateEnd * vEnd) / maxSubstepDepth;
        int nsub = (int)ceil(fmin(need, REAL_C(2.0) * PREINT_CUTOFF / maxSubstepDepth + REAL_C(1.0)));
        nsub = nsub < 1 ? 1 : nsub;
        VEC dv = vEnd / (REAL)nsub;
        VEC dP = Q - P;
        VEC cA[3], dcv[3];
        for (int c = 0; c < 3; ++c) {
            cA[c] = (VEC)(a[c]);
            dcv[c] = ds * slope[c]; /* colour change over the whole piece */
        }
        VEC base = len * (*depth);
        for (int i = 0; i < nsub; ++i) {
            VEC v0 = dv * (REAL)i, v1 = v0 + dv;
            VEC u0 = v0 + dv * glU0, u1 = v0 + dv * glU1, u2 = v0 + dv * glU2;
            VEC e0 = exp(-(base + u0 * (P + REAL_C(0.5) * dP * u0)));
            VEC e1 = exp(-(base + u1 * (P + REAL_C(0.5) * dP * u1)));
            VEC e2 = exp(-(base + u2 * (P + REAL_C(0.5) * dP * u2)));
            VEC ee = exp(-(base + v1 * (P + REAL_C(0.5) * dP * v1)));
            VEC meanT = glW0 * (e0 + e2) + glW1 * e1;
            VEC t0 = *tCur;
            VEC w = t0 - ee, m = meanT - ee;
            *accR += (cA[0] + dcv[0] * v0) * w + dcv[0] * dv * m;
            *accG += (cA[1] + dcv[1] * v0) * w + dcv[1] * dv * m;
            *accB += (cA[2] + dcv[2] * v0) * w + dcv[2] * dv * m;
            *tCur = ee;
        }
        *depth += h * REAL_C(0.5) * (tauA + tauB);
        s = edge;
        k += dir;
    }
}

/* 2D tables: one length, 16 consecutive back nodes per work-item as one vector (gid0 = group of 16 back
   nodes, gid1 = front node). Same integration as preint_exact, vectorised across segments instead of lengths.
 */
__kernel void preint_exact_row(__global const VolclTfKnot* knots, uint knotCount, uint n, REAL lo, REAL hi,
                               REAL len, REAL maxColor, REAL maxSubstepDepth, __global float4* out) {
    uint group = get_global_id(0), jf = get_global_id(1);
    uint ib0 = group * 16;
    if (ib0 >= n || jf >= n) return;
    REAL step = (hi - lo) / (REAL)(n - 1);
    REAL sf = jf == n - 1 ? hi : lo + (REAL)jf * step;
    VEC idx = (VEC)(REAL_C(0.0), REAL_C(1.0), REAL_C(2.0), REAL_C(3.0), REAL_C(4.0), REAL_C(5.0), REAL_C(6.0),
                    REAL_C(7.0), REAL_C(8.0), REAL_C(9.0), REAL_C(10.0), REAL_C(11.0), REAL_C(12.0),
                    REAL_C(13.0), REAL_C(14.0), REAL_C(15.0)) +
              (REAL)ib0;
    idx = fmin(idx, (VEC)((REAL)(n - 1)));
    VEC sb = lo + idx * step;
    sb = idx == (VEC)((REAL)(n - 1)) ? (VEC)(hi) : sb;
    VEC depth = (VEC)(REAL_C(0.0)), tCur = (VEC)(REAL_C(1.0));
    VEC accR = (VEC)(REAL_C(0.0)), accG = accR, accB = accR;
    preint_row_pass(knots, knotCount, sf, sb, len, 1, maxSubstepDepth, &depth, &tCur, &accR, &accG, &accB);
    preint_row_pass(knots, knotCount, sf, sb, len, -1, maxSubstepDepth, &depth, &tCur, &accR, &accG, &accB);
    REAL r[16], g[16], b[16], al[16];
    VEC alpha = preint_one_minus_exp_v(len * depth);
    VEC bound = alpha * maxColor;
    VSTORE(clamp(accR, (VEC)(REAL_C(0.0)), bound), r);
    VSTORE(clamp(accG, (VEC)(REAL_C(0.0)), bound), g);
    VSTORE(clamp(accB, (VEC)(REAL_C(0.0)), bound), b);
    VSTORE(alpha, al);
    for (int l = 0; l < 16; ++l) {
        uint ib = ib0 + (uint)l;
        if (ib >= n) break;
        float4 v = (float4)((float)r[l], (float)g[l], (float)b[l], (float)al[l]);
        if (ib == jf) { /* the diagonal: constant TF along the segment, closed form */
            REAL d[4];
            preint_value_at(knots, knotCount, sf, d);
            REAL a1 = preint_one_minus_exp(len * d[3]);
            v = (float4)((float)(d[0] * a1), (float)(d[1] * a1), (float)(d[2] * a1), (float)a1);
        }
        out[(size_t)jf * n + ib] = v;
    }
}
#endif

/* Weiler-style length recursion (as in VTK's incremental builder): the segment (s_f, s_b, l_k) is the first
   length step l_0 from s_f to s_m = s_f + (s_b - s_f) l_0 / l_k, composited in front of the segment (s_m,
   s_b, l_k - l_0) from the previous slice. Unlike VTK, s_m is not rounded to a node: both lookups interpolate
   linearly between the two nearest nodes. Requires lengths l_k = (k + 1) l_0; one launch per slice k >= 1. */
__kernel void preint_incremental_slice(uint n, uint k, __global float4* table) {
    uint ib = get_global_id(0), jf = get_global_id(1);
    if (ib >= n || jf >= n) return;
    float m = ((float)jf * (float)k + (float)ib) / (float)(k + 1); /* node coordinate of s_m */
    uint m0 = min((uint)m, n - 1), m1 = min(m0 + 1, n - 1);
    float t = m - (float)m0;
    __global const float4* first = table;                          /* slice 0: length l_0 */
    __global const float4* rest = table + (size_t)(k - 1) * n * n; /* slice k-1: length k l_0 */
    float4 front = mix(first[(size_t)jf * n + m0], first[(size_t)jf * n + m1], t);
    float4 back = mix(rest[(size_t)m0 * n + ib], rest[(size_t)m1 * n + ib], t);
    float4 c = front + (1.0f - front.w) * back;
    table[((size_t)k * n + jf) * n + ib] = fmax(c, (float4)(0.0f));
}

/* Engel et al.'s integral-function table: no self-attenuation inside the segment. `integrals` holds, per
   node, (K_r, K_g, K_b, Phi) with K = int c tau ds and Phi = int tau ds from the domain start (computed
   exactly in double on the host); `diag` holds (c tau, tau) at each node for the s_f = s_b limit. */
__kernel void preint_integral_function(__global const REAL* integrals, __global const REAL* diag, uint n,
                                       REAL lo, REAL hi, __global const REAL* lengths, uint lengthCount,
                                       REAL maxColor, __global float4* out) {
    uint ib = get_global_id(0), jf = get_global_id(1), j = get_global_id(2);
    if (ib >= n || jf >= n || j >= lengthCount) return;
    REAL ds = (hi - lo) / (REAL)(n - 1);
    REAL mean[4];
    if (ib == jf) {
        for (int c = 0; c < 4; ++c)
            mean[c] = diag[4 * ib + c];
    } else {
        REAL inv = REAL_C(1.0) / ((REAL)((int)ib - (int)jf) * ds);
        for (int c = 0; c < 4; ++c)
            mean[c] = (integrals[4 * ib + c] - integrals[4 * jf + c]) * inv;
    }
    REAL l = lengths[j];
    REAL a = preint_one_minus_exp(l * fmax(mean[3], REAL_C(0.0)));
    REAL bound = a * maxColor;
    out[((size_t)j * n + jf) * n + ib] =
        (float4)((float)clamp(l * mean[0], REAL_C(0.0), bound), (float)clamp(l * mean[1], REAL_C(0.0), bound),
                 (float)clamp(l * mean[2], REAL_C(0.0), bound), (float)a);
}

/* Roettger's 2D table linear in length (thesis 8.5): entries at l = lBar scaled by l / lBar; where the scaled
   opacity would exceed 1 both colour and opacity are scaled down by the same factor (his clamping rule). */
__kernel void preint_roettger_linear(__global const float4* table2d, uint n, float lBar,
                                     __global const float* lengths, uint lengthCount, __global float4* out) {
    uint ib = get_global_id(0), jf = get_global_id(1), j = get_global_id(2);
    if (ib >= n || jf >= n || j >= lengthCount) return;
    float4 e = table2d[(size_t)jf * n + ib];
    float f = lengths[j] / lBar;
    float a = f * e.w;
    float scale = a > 1.0f ? f / a : f;
    out[((size_t)j * n + jf) * n + ib] = fmax(e * scale, (float4)(0.0f));
}

/* Roettger's 2D+1D model (thesis 9.1): alpha = 1 - exp(-l rhoHat) exactly, colour = alpha * sum_i
   (l / lMax)^i C_i with the chromaticity coefficients C_i fitted through DEGREE + 1 constant-length slices.
   `coeffs` holds per pair DEGREE + 1 float4: (C_i rgb, rhoHat in .w of the first). */
__kernel void preint_polynomial(__global const float4* coeffs, uint n, uint degree, float lMax,
                                float maxColor, __global const float* lengths, uint lengthCount,
                                __global float4* out) {
    uint ib = get_global_id(0), jf = get_global_id(1), j = get_global_id(2);
    if (ib >= n || jf >= n || j >= lengthCount) return;
    __global const float4* c = coeffs + ((size_t)jf * n + ib) * (degree + 1);
    float rhoHat = c[0].w;
    float l = lengths[j];
    float x = l / lMax;
    float3 chroma = c[degree].xyz;
    for (int i = (int)degree - 1; i >= 0; --i)
        chroma = chroma * x + c[i].xyz;
    float a = (float)preint_one_minus_exp((REAL)(l * rhoHat));
    float3 rgb = clamp(chroma * a, 0.0f, a * maxColor);
    out[((size_t)j * n + jf) * n + ib] = (float4)(rgb, a);
}
