/* Brick-resident lifting: one work-item runs every pass of every requested level on one brick, in place.

   Why: the streaming passes of lifting.cl move the whole batch (tens of MB) through memory three times per
   level and ping-pong between two buffers. Here a brick (1 MiB at 64^3 int32 or float) is touched by one
   core only, from its first pass to its last, so it stays in that core's L2; there is no second buffer and
   no copy of the low corner between levels. Work-groups of one work-item (one per brick) spread over the
   cores.

   Lines are lifted 16 at a time, one per vector lane: a y or z "line" is a column of 16 consecutive x.
   5/3 and 9/7 columns with all 16 lanes active are lifted between the brick and a private staging in
   predict+update sweeps (lift_column_direct); x rows of up to 64 samples are lifted along their own
   vectors (lift_row64). Otherwise (partial column groups, longer rows, Haar and 2/6) the 16 lines are
   staged in private memory already split into even (S) and odd (D) samples, for x after transposing 16
   rows in registers so that their samples line up the same way, and the lifting steps run on the staged
   halves. Every form uses the reference's formulas in the reference's order, so the integer forms are
   bit-exact, and none recomputes intermediate steps (the streaming kernels do, to avoid barriers). Step
   by step (Haar, 2/6), the margins (pairs -2, -1 and the two after the last) are refreshed after each
   step from the extension rule, which is how the reference's mirror indexing sees the updated signal.
   Lanes right of the active corner, which hold earlier levels' coefficients, and rows past the corner
   are never changed.

   Extra define: LIFT_MAXN, at least the largest brick dimension, a multiple of 16 (sizes the private
   staging arrays; one program serves every brick shape up to it).
   Optional: VOXEL_TYPE (0 float, 1 uint8, 2 uint16, 3 int16) adds a volume to the kernel. The inverse
   converts each brick, right after its last level, to voxels and writes it at its place in the volume while
   it is still in the core's cache, instead of the host reading it back from memory; the forward reads the
   brick's voxels itself before its first level (and reports their range), instead of the host writing the
   batch first. */

#include "lifting_common.h"

/* Column staging: pairs -2 .. ms + 1, 16 lanes each. */
#define COL_SLOTS (16 * (LIFT_MAXN / 2 + 4))

/* 16-lane accesses at any element alignment through a 4-byte-aligned vector type: one 64-byte load or
   store each, where PoCL's vstore16 stores four 16-byte pieces and a 64-byte load right after them (the
   next lifting step reads what this one stored) stalls on store forwarding. */
typedef V VU __attribute__((aligned(4)));
#define LD(p) (*(const VU*)(p))
#define ST(p, v) (*(VU*)(p) = (v))
#define LDG(p) (*(global const VU*)(p))
#define STG(p, v) (*(global VU*)(p) = (v))

/* A staged half holds each pair as W consecutive 16-lane vectors (W lines side by side per lane group).
   Margin refresh: pairs -2, -1, len, len + 1. Low half: the pair at low_pos (mirror, or clamp for Haar and
   2/6). High half: the pair at high_pos under symmetric extension; zero for Haar and 2/6 (a lone last
   sample has no detail). */
#define ALWAYS_INLINE __attribute__((always_inline)) inline
ALWAYS_INLINE void refresh_low(T* s, int ms, int n, const int W) {
    for (int k = 0; k < 4; ++k) {
        const int m = k < 2 ? k - 2 : ms + k - 2, src = low_pos(m, n);
        for (int w = 0; w < W; ++w)
            ST(s + 16 * (m * W + w), LD(s + 16 * (src * W + w)));
    }
}
ALWAYS_INLINE void refresh_high(T* d, int md, int n, const int W) {
    for (int k = 0; k < 4; ++k) {
        const int m = k < 2 ? k - 2 : md + k - 2;
        for (int w = 0; w < W; ++w)
#if SYMMETRIC_EXTENSION
            ST(d + 16 * (m * W + w), LD(d + 16 * (high_pos(m, n) * W + w)));
#else
            ST(d + 16 * (m * W + w), (V)(0));
#endif
    }
}

/* One lifting step over the pairs of a half: D[m] += F(a, b) with a = S[m], b = S[m + 1] (STEP_HIGH),
   S[m] += F(a, b) with a = D[m - 1], b = D[m] (STEP_LOW), or D[m] += F(a, b) with a = S[m - 1], b = S[m + 1]
   (STEP_HIGH_OUTER, the 2/6 prediction); then the updated half's margins are refreshed. Vector v of the
   half belongs to pair v / W, so the neighbour pair is W vectors away. */
#define STEP(dst, src, lo, hi, F, pairs)                                                                     \
    for (int v = 0; v < (pairs)*W; ++v) {                                                                    \
        const V a = LD((src) + 16 * (v + (lo)*W)), b = LD((src) + 16 * (v + (hi)*W));                        \
        ST((dst) + 16 * v, LD((dst) + 16 * v) + (F));                                                        \
    }
#define STEP_HIGH(F) STEP(D, S, 0, 1, F, md) refresh_high(D, md, n, W);
#define STEP_LOW(F) STEP(S, D, -1, 0, F, ms) refresh_low(S, ms, n, W);
#define STEP_HIGH_OUTER(F) STEP(D, S, -1, 1, F, md) refresh_high(D, md, n, W);
#if WAVELET <= 1
/* A predict + update pair of lifting steps (5/3: the whole wavelet; 9/7: two such pairs) in one sweep per
   lane group: both steps of pair m are done before pair m + 1 (the prediction d[m] is ready when the
   update of s[m] needs it; d[m - 1] is carried in a register), so each vector is loaded and stored once
   per pair of steps, and the symmetric extension is applied at the two ends instead of refreshing
   margins: d[-1] = d[0]; e[ms] = e[ms - 1] (even n); d[md] = d[md - 1] (odd n). Forward: d[m] = o[m] +
   PRED(e[m] + e[m + 1]), s[m] = e[m] + UPD(d[m - 1] + d[m]), stored as OUT_S(s), OUT_D(d). Inverse: the
   inputs are read as IN_S(s), IN_D(d), then e[m] = s[m] - UPD(d[m - 1] + d[m]), o[m] = d[m] - PRED(e[m] +
   e[m + 1]). The same formulas in the same order per sample as the reference, so the integer 5/3 is
   bit-exact.
   Inputs and outputs are separate (pointer, elements from one pair to the next) in the address spaces
   IS, ID, OS, OD, so a sweep can read the brick and write the staging, or the other way round, or work in
   place: a column pass moves each sample between the brick and L1 once instead of staging it first. In
   place on the brick is safe where a sweep stores only positions it has read (forward: s[m] to m after
   reading up to 2m + 2; inverse: e and o to 2m, 2m + 1 before d[m + 1] at ms + m + 1 is read, the s half
   being staged). */
#define LDQ(q, p) (*(q const VU*)(p))
#define STQ(q, p, v) (*(q VU*)(p) = (v))
#define DEFINE_SWEEP_FORWARD(name, PRED, UPD, OUT_S, OUT_D, IS, ID, OS, OD)                                  \
    ALWAYS_INLINE void name(IS T* s, size_t ps, ID T* d, size_t pd, OS T* os, size_t qs, OD T* od,           \
                            size_t qd, int n) {                                                              \
        const int ms = (n + 1) >> 1, md = n >> 1;                                                            \
        V em = LDQ(IS, s);                                                                                   \
        V ep = ms > 1 ? LDQ(IS, s + ps) : em;                                                                \
        V dm = LDQ(ID, d) + PRED(em + ep), dm1 = dm;                                                         \
        for (int m = 0; m < ms; ++m) {                                                                       \
            /* em = e[m], ep = e[m + 1], dm = d[m], dm1 = d[m - 1] */                                        \
            STQ(OS, os + m * qs, OUT_S(em + UPD(dm1 + dm)));                                                 \
            if (m < md) STQ(OD, od + m * qd, OUT_D(dm));                                                     \
            dm1 = dm;                                                                                        \
            em = ep;                                                                                         \
            if (m + 1 < md) {                                                                                \
                ep = m + 2 < ms ? LDQ(IS, s + (m + 2) * ps) : em;                                            \
                dm = LDQ(ID, d + (m + 1) * pd) + PRED(em + ep);                                              \
            }                                                                                                \
        }                                                                                                    \
    }
#define DEFINE_SWEEP_INVERSE(name, PRED, UPD, IN_S, IN_D, IS, ID, OS, OD)                                    \
    ALWAYS_INLINE void name(IS T* s, size_t ps, ID T* d, size_t pd, OS T* os, size_t qs, OD T* od,           \
                            size_t qd, int n) {                                                              \
        const int ms = (n + 1) >> 1, md = n >> 1;                                                            \
        V dm = IN_D(LDQ(ID, d));                                                                             \
        V em = IN_S(LDQ(IS, s)) - UPD(dm + dm);                                                              \
        for (int m = 0; m < ms; ++m) {                                                                       \
            /* em = e[m], dm = d[m]; dn = d[m + 1], en = e[m + 1] */                                         \
            const V dn = m + 1 < md ? IN_D(LDQ(ID, d + (m + 1) * pd)) : dm;                                  \
            const V en = m + 1 < ms ? IN_S(LDQ(IS, s + (m + 1) * ps)) - UPD(dm + dn) : em;                   \
            STQ(OS, os + m * qs, em);                                                                        \
            if (m < md) STQ(OD, od + m * qd, dm - PRED(em + en));                                            \
            em = en;                                                                                         \
            dm = dn;                                                                                         \
        }                                                                                                    \
    }
/* Each sweep in four forms: on the staging (suffix _p), brick to staging (_bp), staging to brick (_pb),
   and brick to brick with one half staged (_bb, the 5/3's: forward writes d to the staging, inverse reads
   s from it; BB_SPACES, since the macro argument holds commas, goes through DEFINE_SWEEP_ to expand). */
#ifndef LIFT_INVERSE
#define DEFINE_SWEEP DEFINE_SWEEP_FORWARD
#define BB_SPACES global, global, global, private
#else
#define DEFINE_SWEEP DEFINE_SWEEP_INVERSE
#define BB_SPACES private, global, global, global
#endif
#define DEFINE_SWEEP_(...) DEFINE_SWEEP(__VA_ARGS__)
#define DEFINE_SWEEPS(name, PRED, UPD, OUT_S, OUT_D)                                                         \
    DEFINE_SWEEP(name##_p, PRED, UPD, OUT_S, OUT_D, private, private, private, private)                      \
    DEFINE_SWEEP(name##_bp, PRED, UPD, OUT_S, OUT_D, global, global, private, private)                       \
    DEFINE_SWEEP(name##_pb, PRED, UPD, OUT_S, OUT_D, private, private, global, global)                       \
    DEFINE_SWEEP_(name##_bb, PRED, UPD, OUT_S, OUT_D, BB_SPACES)
#define AS_IS(v) (v)
#if WAVELET == 0
#define PRED53(v) (-HALF(v))
#define UPD53(v) QUARTER_R(v)
DEFINE_SWEEPS(sweep53, PRED53, UPD53, AS_IS, AS_IS)
#else
#define PRED97A(v) (L97_A * (v))
#define UPD97B(v) (L97_B * (v))
#define PRED97G(v) (L97_G * (v))
#define UPD97D(v) (L97_D * (v))
#define SCALE_LOW(v) ((v) * (1.0f / L97_K))
#define SCALE_HIGH(v) ((v) * (0.5f * L97_K))
#define UNSCALE_LOW(v) ((v)*L97_K)
#define UNSCALE_HIGH(v) ((v) * (2.0f / L97_K))
#ifndef LIFT_INVERSE
DEFINE_SWEEPS(sweep97ab, PRED97A, UPD97B, AS_IS, AS_IS)
DEFINE_SWEEPS(sweep97gd, PRED97G, UPD97D, SCALE_LOW, SCALE_HIGH)
#else
DEFINE_SWEEPS(sweep97gd, PRED97G, UPD97D, UNSCALE_LOW, UNSCALE_HIGH)
DEFINE_SWEEPS(sweep97ab, PRED97A, UPD97B, AS_IS, AS_IS)
#endif
#endif
#endif

/* The lifting steps of the wavelet on the staged halves of 16 W lines of n >= 2 samples: S[16 (m W + w) +
   lane] is the even sample (low coefficient) of pair m, D the odd one (high), m in [-2, ms + 2). */
ALWAYS_INLINE void lift_halves(T* S, T* D, int n, const int W) {
    for (int w = 0; w < W; ++w) {
#if WAVELET == 0
        sweep53_p(S + 16 * w, 16 * W, D + 16 * w, 16 * W, S + 16 * w, 16 * W, D + 16 * w, 16 * W, n);
#elif WAVELET == 1 && !defined(LIFT_INVERSE)
        sweep97ab_p(S + 16 * w, 16 * W, D + 16 * w, 16 * W, S + 16 * w, 16 * W, D + 16 * w, 16 * W, n);
        sweep97gd_p(S + 16 * w, 16 * W, D + 16 * w, 16 * W, S + 16 * w, 16 * W, D + 16 * w, 16 * W, n);
#elif WAVELET == 1
        sweep97gd_p(S + 16 * w, 16 * W, D + 16 * w, 16 * W, S + 16 * w, 16 * W, D + 16 * w, 16 * W, n);
        sweep97ab_p(S + 16 * w, 16 * W, D + 16 * w, 16 * W, S + 16 * w, 16 * W, D + 16 * w, 16 * W, n);
#endif
    }
#if WAVELET >= 2 /* Haar and 2/6: step by step with margin refreshes (comparison filters, not tuned) */
    const int ms = (n + 1) >> 1, md = n >> 1;
    refresh_low(S, ms, n, W);
    refresh_high(D, md, n, W);
#ifndef LIFT_INVERSE
    STEP_HIGH(-a)
    STEP_LOW(HALF(b))
#if WAVELET == 3
    STEP_HIGH_OUTER(QUARTER_R(a - b))
#endif
#else
#if WAVELET == 3
    STEP_HIGH_OUTER(-QUARTER_R(a - b))
#endif
    STEP_LOW(-HALF(b))
    STEP_HIGH(a)
#endif
#endif
}

/* Lanes [0, lim) of a column vector (the lanes right of the active corner keep their data). */
inline void store_lanes(global T* p, V v, int lim) {
    if (lim >= 16) {
        STG(p, v);
        return;
    }
    T t[16];
    ST(t, v);
    for (int i = 0; i < lim; ++i)
        p[i] = t[i];
}

/* 16 x 16 transpose of m[0..15] (m[r] lane c -> m[c] lane r): four perfect-shuffle rounds of 16 shuffles. */
ALWAYS_INLINE void transpose16(V* m) {
#pragma unroll
    for (int round = 0; round < 4; ++round) {
        V t[16];
#pragma unroll
        for (int i = 0; i < 8; ++i) {
            t[2 * i] =
                shuffle2(m[i], m[i + 8], (uint16)(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23));
            t[2 * i + 1] = shuffle2(m[i], m[i + 8],
                                    (uint16)(8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31));
        }
#pragma unroll
        for (int i = 0; i < 16; ++i)
            m[i] = t[i];
    }
}

/* Up to 16 rows of n >= 2 samples (`rows` of them, `pitch` apart), in place. Why transposed: a row is short
   (64 samples), so lifting it along its own vectors pays margins and cross-lane neighbours on every row;
   with the 16 rows as the 16 lanes, an x line is lifted exactly like a y or z column (lift_halves, whole
   aligned vectors only), and the transposes cost 4 shuffles per vector each way. Lanes past `rows` repeat
   the last row and are never stored. */
inline void lift_rows(global T* first, size_t pitch, int n, int rows) {
    const int ms = (n + 1) >> 1, md = n >> 1;
    T sbuf[COL_SLOTS], dbuf[COL_SLOTS];
    T* S = sbuf + 32;
    T* D = dbuf + 32;
    for (int x0 = 0; x0 < n; x0 += 16) {
        V m[16];
#pragma unroll
        for (int r = 0; r < 16; ++r)
            m[r] = LDG(first + min(r, rows - 1) * pitch + x0);
        transpose16(m);
#pragma unroll
        for (int c = 0; c < 16; ++c) {
            const int x = x0 + c;
            if (x >= n) break;
#ifndef LIFT_INVERSE
            ST(((x & 1) ? D : S) + 16 * (x >> 1), m[c]);
#else
            ST(x < ms ? S + 16 * x : D + 16 * (x - ms), m[c]);
#endif
        }
    }
    lift_halves(S, D, n, 1);
    for (int x0 = 0; x0 < n; x0 += 16) {
        V m[16];
#pragma unroll
        for (int c = 0; c < 16; ++c) {
            const int x = min(x0 + c, n - 1);
#ifndef LIFT_INVERSE
            m[c] = x < ms ? LD(S + 16 * x) : LD(D + 16 * (x - ms));
#else
            m[c] = LD(((x & 1) ? D : S) + 16 * (x >> 1));
#endif
        }
        transpose16(m);
        /* unrolled with constant indices so m[] stays in registers */
        if (n - x0 >= 16) {
#pragma unroll
            for (int r = 0; r < 16; ++r)
                if (r < rows) STG(first + r * pitch + x0, m[r]);
        } else {
#pragma unroll
            for (int r = 0; r < 16; ++r)
                if (r < rows) store_lanes(first + r * pitch + x0, m[r], n - x0);
        }
    }
}

#if WAVELET <= 1
/* The x pass on rows of 2 .. 64 samples without transposes: a row is four 16-lane vectors, split into its
   even (E) and odd (O) halves of up to 32 samples by constant shuffles, and each lifting step is vector
   arithmetic between a half and its neighbour-shifted copy (one constant shuffle per vector, plus a select
   for the extension at the ends). Why: the transposes of lift_rows cost 8 shuffles per vector and, as
   PoCL's LLVM compiled them, spills; this is about 2-3 shuffles per vector. Lanes past a half's length
   hold garbage that never reaches a valid lane. Stores of partial vectors blend with what memory holds
   (the lanes past the active row keep earlier levels' coefficients) but never write past the row's pitch
   (store_part); the unaligned loads of the inverse may read up to 16 elements past the row, which
   BrickBatch's slack covers at the buffer end. */
#define LANE ((int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
/* Lanes [0, count) of v to p, count >= 1; `room` elements from p to the end of the row's pitch. A partial
   vector is blended with what memory holds, which rewrites the lanes past count with the values read: safe
   within this brick (only this work-item writes it) but not past the pitch of a brick's last row, where the
   next brick begins and another work-item may be changing it (seen as lost updates: the codec's lossless
   round trips of awkward sizes with small edge bricks failed now and then once PoCL's workers were pinned
   and ran bricks at the same time). There, lane by lane. */
ALWAYS_INLINE void store_part(global T* p, V v, int count, int room) {
    if (count >= 16) {
        STG(p, v);
    } else if (room >= 16) {
        STG(p, select(LDG(p), v, LANE < count));
    } else {
        T t[16];
        ST(t, v);
        for (int i = 0; i < count; ++i)
            p[i] = t[i];
    }
}
/* 16 elements from p, or the first `room` (>= 1) of them and zeros when fewer are left in the brick: the
   inverse's unaligned loads may reach 16 elements past the row (lanes nothing reads), and past the pitch of
   a brick's last row lies the next brick, which another work-item may be writing: reading it there is a
   data race (Oclgrind reports it), whatever the lanes are used for. */
ALWAYS_INLINE V load_part(global const T* p, size_t room) {
    if (room >= 16) return LDG(p);
    T t[16];
    for (int i = 0; i < 16; ++i)
        t[i] = i < (int)room ? p[i] : (T)0;
    return LD(t);
}
/* x[m + 1] of a half (lo = x[0..16), hi = x[16..32)) of length len: x[m] itself at m = len - 1, which is
   where the whole-sample symmetric extension sends e[ms] for even n (other lanes past len: don't care). */
#define NEXT(lo, hi, len, nlo, nhi)                                                                          \
    nlo = select(lo, shuffle2(lo, hi, (uint16)(1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16)),      \
                 LANE + 1 < (len));                                                                          \
    nhi = select(hi, shuffle(hi, (uint16)(1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 15)),           \
                 LANE + 17 < (len));
/* x[m - 1] (the extension gives d[-1] = d[0]) and x[m] clamped to len - 1 (d[md] = d[md - 1] for odd n). */
#define PREV_CUR(lo, hi, len, plo, phi, clo, chi)                                                            \
    plo = shuffle(lo, (uint16)(0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14));                        \
    phi = shuffle2(lo, hi, (uint16)(15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30));        \
    clo = select(plo, lo, LANE < (len));                                                                     \
    chi = select(phi, hi, LANE + 16 < (len));
/* O += PRED(E + E[m + 1]) and E += UPD(O[m - 1] + O[m]), forward (sign +) or undone (sign -), with the
   same formulas per sample as the reference (bit-exact for the integer 5/3). */
#define PREDICT(sign, PRED)                                                                                  \
    {                                                                                                        \
        V n0, n1;                                                                                            \
        NEXT(e0, e1, ms, n0, n1)                                                                             \
        o0 = o0 sign PRED(e0 + n0);                                                                          \
        o1 = o1 sign PRED(e1 + n1);                                                                          \
    }
#define UPDATE(sign, UPD)                                                                                    \
    {                                                                                                        \
        V p0, p1, c0, c1;                                                                                    \
        PREV_CUR(o0, o1, md, p0, p1, c0, c1)                                                                 \
        e0 = e0 sign UPD(p0 + c0);                                                                           \
        e1 = e1 sign UPD(p1 + c1);                                                                           \
    }
#define EVENS (uint16)(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30)
#define ODDS (uint16)(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31)
#define ZIP_LO (uint16)(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23)
#define ZIP_HI (uint16)(8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31)

/* One row of 2 <= n <= 64 samples, in place; `room` elements from row to the end of the brick. */
ALWAYS_INLINE void lift_row64(global T* row, int n, int px, size_t room) {
    const int ms = (n + 1) >> 1, md = n >> 1;
    V e0, e1, o0, o1;
#ifndef LIFT_INVERSE
    /* only the vectors the row reaches: the last row of the buffer ends at its pitch */
    const V v0 = LDG(row);
    const V v1 = n > 16 ? LDG(row + 16) : v0;
    const V v2 = n > 32 ? LDG(row + 32) : v1;
    const V v3 = n > 48 ? LDG(row + 48) : v2;
    e0 = shuffle2(v0, v1, EVENS);
    o0 = shuffle2(v0, v1, ODDS);
    e1 = shuffle2(v2, v3, EVENS);
    o1 = shuffle2(v2, v3, ODDS);
#if WAVELET == 0
    PREDICT(+, PRED53)
    UPDATE(+, UPD53)
#else
    PREDICT(+, PRED97A)
    UPDATE(+, UPD97B)
    PREDICT(+, PRED97G)
    UPDATE(+, UPD97D)
    e0 = SCALE_LOW(e0);
    e1 = SCALE_LOW(e1);
    o0 = SCALE_HIGH(o0);
    o1 = SCALE_HIGH(o1);
#endif
    store_part(row, e0, ms, px);
    if (ms > 16) store_part(row + 16, e1, ms - 16, px - 16);
    store_part(row + ms, o0, md, px - ms);
    if (md > 16) store_part(row + ms + 16, o1, md - 16, px - ms - 16);
#else
    e0 = LDG(row);
    e1 = ms > 16 ? LDG(row + 16) : e0;
    o0 = load_part(row + ms, room - (size_t)ms);
    o1 = md > 16 ? load_part(row + ms + 16, room - (size_t)ms - 16) : o0;
#if WAVELET == 0
    UPDATE(-, UPD53)
    PREDICT(-, PRED53)
#else
    e0 = UNSCALE_LOW(e0);
    e1 = UNSCALE_LOW(e1);
    o0 = UNSCALE_HIGH(o0);
    o1 = UNSCALE_HIGH(o1);
    UPDATE(-, UPD97D)
    PREDICT(-, PRED97G)
    UPDATE(-, UPD97B)
    PREDICT(-, PRED97A)
#endif
    store_part(row, shuffle2(e0, o0, ZIP_LO), n, px);
    if (n > 16) store_part(row + 16, shuffle2(e0, o0, ZIP_HI), n - 16, px - 16);
    if (n > 32) store_part(row + 32, shuffle2(e1, o1, ZIP_LO), n - 32, px - 32);
    if (n > 48) store_part(row + 48, shuffle2(e1, o1, ZIP_HI), n - 48, px - 48);
#endif
}
#endif

/* W columns of 16 consecutive x side by side (lanes [0, lim) of the 16 W active) with n >= 2 samples
   `stride` apart, in place. W = 4 reads 256 contiguous bytes per sample rather than 64, since the z pass's
   samples are a plane (16 KB) apart; on the shared test machine it measured no slower than W = 1, and any
   gain was within the noise. */
ALWAYS_INLINE void lift_column(global T* col, size_t stride, int n, int lim, const int W) {
    const int ms = (n + 1) >> 1, md = n >> 1;
    T sbuf[4 * COL_SLOTS], dbuf[4 * COL_SLOTS];
    T* S = sbuf + 32 * W;
    T* D = dbuf + 32 * W;
#ifndef LIFT_INVERSE
#define SRC_S(m) (2 * (m))
#define SRC_D(m) (2 * (m) + 1)
#define DST_S(m) (m)
#define DST_D(m) (ms + (m))
#else
#define SRC_S(m) (m)
#define SRC_D(m) (ms + (m))
#define DST_S(m) (2 * (m))
#define DST_D(m) (2 * (m) + 1)
#endif
    for (int m = 0; m < ms; ++m)
        for (int w = 0; w < W; ++w)
            ST(S + 16 * (m * W + w), LDG(col + SRC_S(m) * stride + 16 * w));
    for (int m = 0; m < md; ++m)
        for (int w = 0; w < W; ++w)
            ST(D + 16 * (m * W + w), LDG(col + SRC_D(m) * stride + 16 * w));
    lift_halves(S, D, n, W);
    for (int m = 0; m < ms; ++m)
        for (int w = 0; w < W && 16 * w < lim; ++w)
            store_lanes(col + DST_S(m) * stride + 16 * w, LD(S + 16 * (m * W + w)), lim - 16 * w);
    for (int m = 0; m < md; ++m)
        for (int w = 0; w < W && 16 * w < lim; ++w)
            store_lanes(col + DST_D(m) * stride + 16 * w, LD(D + 16 * (m * W + w)), lim - 16 * w);
#undef SRC_S
#undef SRC_D
#undef DST_S
#undef DST_D
}

#if WAVELET <= 1
/* 16 columns of n >= 2 samples `stride` apart, every lane active, lifted between the brick and the staging
   without a separate staging copy (see the sweeps): 5/3 goes brick to brick with one half staged, 9/7
   brick to staging in its first sweep and back in its second. */
ALWAYS_INLINE void lift_column_direct(global T* col, size_t stride, int n) {
    const int ms = (n + 1) >> 1, md = n >> 1;
    T sbuf[COL_SLOTS], dbuf[COL_SLOTS];
#if WAVELET == 0 && !defined(LIFT_INVERSE)
    sweep53_bb(col, 2 * stride, col + stride, 2 * stride, col, stride, dbuf, 16, n);
    for (int m = 0; m < md; ++m)
        STG(col + (ms + m) * stride, LD(dbuf + 16 * m));
#elif WAVELET == 0
    for (int m = 0; m < ms; ++m)
        ST(sbuf + 16 * m, LDG(col + m * stride));
    sweep53_bb(sbuf, 16, col + ms * stride, stride, col, 2 * stride, col + stride, 2 * stride, n);
#elif !defined(LIFT_INVERSE)
    sweep97ab_bp(col, 2 * stride, col + stride, 2 * stride, sbuf, 16, dbuf, 16, n);
    sweep97gd_pb(sbuf, 16, dbuf, 16, col, stride, col + ms * stride, stride, n);
#else
    sweep97gd_bp(col, stride, col + ms * stride, stride, sbuf, 16, dbuf, 16, n);
    sweep97ab_pb(sbuf, 16, dbuf, 16, col, 2 * stride, col + stride, 2 * stride, n);
#endif
}
#endif

/* The y or z pass over the active columns of one plane-row: 64-wide groups where the row pitch allows
   (never reading past it: the last row may end the buffer), then 16-wide ones. */
inline void lift_columns(global T* first, size_t stride, int n, int nx, int px) {
    int x = 0;
#if WAVELET <= 1
    for (; nx - x >= 16; x += 16)
        lift_column_direct(first + x, stride, n);
#endif
    for (; nx - x > 16 && x + 64 <= px; x += 64)
        lift_column(first + x, stride, n, nx - x, 4);
    for (; x < nx; x += 16)
        lift_column(first + x, stride, n, nx - x, 1);
}

/* The x, y and z passes of one level (z, y, x for the inverse) on the active corner (nx, ny, nz) of a
   brick with row pitch px and by rows per plane; a length-1 axis is passed through. */
inline void lift_level(global T* brick, int px, int by, int nx, int ny, int nz) {
    const size_t plane = (size_t)px * by;
    for (int step = 0; step < 3; ++step) {
#ifdef LIFT_INVERSE
        const int axis = 2 - step;
#else
        const int axis = step;
#endif
        if (axis == 0) {
            if (nx < 2) {
#if WAVELET <= 1
            } else if (nx <= 64) {
                for (int z = 0; z < nz; ++z)
                    for (int y = 0; y < ny; ++y)
                        lift_row64(brick + z * plane + (size_t)y * px, nx, px,
                                   ((size_t)(nz - z) * by - (size_t)y) * px); /* at least what is left */
#endif
            } else {
                for (int z = 0; z < nz; ++z)
                    for (int y = 0; y < ny; y += 16)
                        lift_rows(brick + z * plane + (size_t)y * px, (size_t)px, nx, min(16, ny - y));
            }
        } else if (axis == 1) {
            if (ny > 1)
                for (int z = 0; z < nz; ++z)
                    lift_columns(brick + z * plane, (size_t)px, ny, nx, px);
        } else if (nz > 1) {
            for (int y = 0; y < ny; ++y)
                lift_columns(brick + (size_t)y * px, plane, nz, nx, px);
        }
    }
}

#ifdef VOXEL_TYPE
/* Voxels as the host's placement makes them: lossy floats rounded to nearest even, integers clamped to the
   type's range. Spelled out as rint, clamp and a plain conversion: PoCL's convert_*_sat_rte builtins
   compile to long compare-and-select chains. */
#if VOXEL_TYPE == 1
typedef uchar voxel_t;
typedef uchar16 voxel16;
#define VOXEL_MIN 0
#define VOXEL_MAX 255
#define CONVERT_VOXEL convert_uchar16
#elif VOXEL_TYPE == 2
typedef ushort voxel_t;
typedef ushort16 voxel16;
#define VOXEL_MIN 0
#define VOXEL_MAX 65535
#define CONVERT_VOXEL convert_ushort16
#elif VOXEL_TYPE == 3
typedef short voxel_t;
typedef short16 voxel16;
#define VOXEL_MIN (-32768)
#define VOXEL_MAX 32767
#define CONVERT_VOXEL convert_short16
#else
typedef float voxel_t;
typedef float16 voxel16;
#endif
#if VOXEL_TYPE == 0 && defined(LIFT_FLOAT)
#define TO_VOXEL(v) (v)
#elif VOXEL_TYPE == 0
#define TO_VOXEL(v) convert_float16(v)
#elif defined(LIFT_FLOAT)
#define TO_VOXEL(v) CONVERT_VOXEL(convert_int16(clamp(rint(v), (float16)(VOXEL_MIN), (float16)(VOXEL_MAX))))
#else
#define TO_VOXEL(v) CONVERT_VOXEL(clamp((v), (int16)(VOXEL_MIN), (int16)(VOXEL_MAX)))
#endif
/* One load or store per vector at any alignment (vload16/vstore16 of small types are split into single
   elements). */
typedef voxel16 voxel16u __attribute__((aligned(sizeof(voxel_t))));
#ifdef LIFT_FLOAT
#define FROM_VOXEL(v) convert_float16(v)
#define VMIN fmin
#define VMAX fmax
#else
#define FROM_VOXEL(v) convert_int16(v)
#define VMIN min
#define VMAX max
#endif

#ifndef LIFT_INVERSE
/* The forward transform's input: the nx x ny x nz brick of voxels at `in` (rows `row`, planes `plane` apart)
   converted into the brick (row pitch px, by rows per plane) with zeros in each row's padding up to px (the
   x pass computes whole vectors there, and old integers read as floats would be denormals). Returns the
   brick's smallest and largest voxel in range[0], range[1]. A row's last partial vector is loaded lane by
   lane, so no read leaves the volume. */
inline void load_voxels(global T* brick, int px, int by, int nx, int ny, int nz, global const voxel_t* in,
                        ulong row, ulong plane, global T* range) {
    V lo = (V)((T)in[0]), hi = lo;
    for (int z = 0; z < nz; ++z)
        for (int y = 0; y < ny; ++y) {
            global const voxel_t* src = in + z * plane + y * row;
            global T* dst = brick + ((size_t)z * by + y) * px;
            int x = 0;
            for (; x + 16 <= nx; x += 16) {
                const V v = FROM_VOXEL(*(global const voxel16u*)(src + x));
                lo = VMIN(lo, v);
                hi = VMAX(hi, v);
                STG(dst + x, v);
            }
            if (x < nx) {
                T t[16], m[16];
                for (int i = 0; i < 16; ++i) {
                    const bool inside = x + i < nx;
                    t[i] = inside ? (T)src[x + i] : (T)0;
                    m[i] = inside ? t[i] : (T)src[x]; /* neutral for min and max */
                }
                const V v = LD(t), w = LD(m);
                lo = VMIN(lo, w);
                hi = VMAX(hi, w);
                STG(dst + x, v);
                x += 16;
            }
            for (; x < px; x += 16)
                STG(dst + x, (V)(0));
        }
    T l[16], h[16];
    ST(l, lo);
    ST(h, hi);
    T a = l[0], b = h[0];
    for (int i = 1; i < 16; ++i) {
        a = min(a, l[i]);
        b = max(b, h[i]);
    }
    range[0] = a;
    range[1] = b;
}
#endif

/* The nx x ny x nz brick (row pitch px, by rows per plane) as voxels at `out`, rows `row` and planes `plane`
   apart. A row's last partial vector is stored lane by lane: the next brick's voxels follow it in the volume
   and another work-item may be writing them. */
#ifdef LIFT_INVERSE
inline void store_voxels(global const T* brick, int px, int by, int nx, int ny, int nz, global voxel_t* out,
                         ulong row, ulong plane) {
    for (int z = 0; z < nz; ++z)
        for (int y = 0; y < ny; ++y) {
            global const T* src = brick + ((size_t)z * by + y) * px;
            global voxel_t* dst = out + z * plane + y * row;
            int x = 0;
            for (; x + 16 <= nx; x += 16)
                *(global voxel16u*)(dst + x) = TO_VOXEL(LDG(src + x));
            if (x < nx) {
                voxel_t t[16];
                *(voxel16u*)t = TO_VOXEL(LDG(src + x));
                for (int i = 0; x + i < nx; ++i)
                    dst[x + i] = t[i];
            }
        }
}
#endif
#endif

/* Each work-item takes bricks from the shared counter `next` (zero at launch) until none is left; forward
   levels 0 .. levels-1, or inverse levels levels-1 .. stop. Bricks come from up to kMaxShapes batches (one
   per brick shape, buffers d0 .. d7): batch k holds bricks end[k - 1] .. end[k] - 1 of the counter, of
   bx[k] x by[k] x bz[k] with row pitch px[k], stacked along z; unused batches repeat the last buffer.
   Why a counter instead of one work-group per brick: PoCL hands a thread the first 1 + n/2 of n
   work-groups in one chunk, so with a dozen bricks one core took most of them while the other idled;
   pulling bricks one at a time balances the cores whatever the chunking. Why every shape in one launch:
   a volume's edge bricks come in up to 8 shapes of a few bricks each, and a launch per shape paid its
   overhead and left a core idle at the end of each (the host orders the batches largest bricks first,
   so the last bricks handed out are the small ones). */
kernel __attribute__((reqd_work_group_size(1, 1, 1))) void lift_bricks(
    global T* d0, global T* d1, global T* d2, global T* d3, global T* d4, global T* d5, global T* d6,
    global T* d7, volatile global int* next, uint8 px8, uint8 bx8, uint8 by8, uint8 bz8, uint8 end8,
    uint levels,
    uint stop
#ifdef VOXEL_TYPE
    /* Inverse: brick c goes to vox + vox_offset[c] (stop is 0). Forward: brick c comes from there, and its
       voxel range goes to range[2c], range[2c + 1]. */
    ,
    global voxel_t* vox, global const ulong* vox_offset, ulong vox_row, ulong vox_plane
#ifndef LIFT_INVERSE
    ,
    global T* range
#endif
#endif
) {
    uint px[8], bx[8], by[8], bz[8], end[8];
    vstore8(px8, 0, px);
    vstore8(bx8, 0, bx);
    vstore8(by8, 0, by);
    vstore8(bz8, 0, bz);
    vstore8(end8, 0, end);
    for (;;) {
        const int c = atomic_inc(next);
        if (c >= (int)end[7]) return;
        int k = 0;
        while (c >= (int)end[k])
            ++k;
        global T* const base[8] = {d0, d1, d2, d3, d4, d5, d6, d7};
        const size_t i = (size_t)(c - (k > 0 ? (int)end[k - 1] : 0));
        global T* brick = base[k] + i * px[k] * by[k] * bz[k];
#if defined(VOXEL_TYPE) && !defined(LIFT_INVERSE)
        load_voxels(brick, px[k], by[k], bx[k], by[k], bz[k], vox + vox_offset[c], vox_row, vox_plane,
                    range + 2 * c);
#endif
#ifdef LIFT_INVERSE
        for (int l = (int)levels - 1; l >= (int)stop; --l)
#else
        for (int l = 0; l < (int)levels; ++l)
#endif
            lift_level(brick, px[k], by[k], ((bx[k] - 1) >> l) + 1, ((by[k] - 1) >> l) + 1,
                       ((bz[k] - 1) >> l) + 1);
#if defined(VOXEL_TYPE) && defined(LIFT_INVERSE)
        store_voxels(brick, px[k], by[k], bx[k], by[k], bz[k], vox + vox_offset[c], vox_row, vox_plane);
#endif
    }
}
