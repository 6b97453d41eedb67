/* Separable 1D lifting passes (forward and inverse) along x, y or z over a batch of equally sized bricks,
   one streaming launch per pass: the general path, for GPUs and large bricks (lifting_brick.cl is the
   fast path on CPU devices).

   Buffer layout: bricks stacked along z, each brick (px x by x bz) with row pitch px (a multiple of 16).
   A pass works on the active corner (nx, ny, nz) of every brick: low coefficients go to the first
   ceil(n/2) slots of a line, high coefficients to the next floor(n/2) (Mallat layout). Passes read one
   buffer and write the other. Defines, types and extension rules: lifting_common.h.

   Why one work-item computes a whole (low, high) pair from a window: recomputing the intermediate
   lifting steps from a 5-pair window needs no barriers, so the passes stay streaming kernels, and
   explicit 16-wide vectors along x reach PoCL's copy ceiling (see notes/pocl-performance.md). */

#include "lifting_common.h"

/* ---- per-wavelet pair computations, written once for scalar T and vector V ----
   Forward inputs: e_k, o_k = even/odd samples of pair n+k (k = m2..p2). Outputs s_out, d_out.
   Inverse inputs: s_k, d_k = low/high coefficients of pair n+k. Outputs e_out, o_out.
   `lone`: pair n has no odd sample (last pair of an odd-length line). */
#if WAVELET == 0
#define FWD_BODY(TY)                                                                                         \
    {                                                                                                        \
        TY dm1 = o_m1 - HALF(e_m1 + e_0);                                                                    \
        TY d0 = o_0 - HALF(e_0 + e_p1);                                                                      \
        s_out = e_0 + QUARTER_R(dm1 + d0);                                                                   \
        d_out = d0;                                                                                          \
    }
#define INV_BODY(TY)                                                                                         \
    {                                                                                                        \
        TY e0 = s_0 - QUARTER_R(d_m1 + d_0);                                                                 \
        TY e1 = s_p1 - QUARTER_R(d_0 + d_p1);                                                                \
        e_out = e0;                                                                                          \
        o_out = d_0 + HALF(e0 + e1);                                                                         \
    }
#define WIN_FWD_E_LO (-1)
#define WIN_FWD_E_HI 1
#define WIN_FWD_O_LO (-1)
#define WIN_FWD_O_HI 0
#define WIN_INV_S_LO 0
#define WIN_INV_S_HI 1
#define WIN_INV_D_LO (-1)
#define WIN_INV_D_HI 1
#elif WAVELET == 1
#define FWD_BODY(TY)                                                                                         \
    {                                                                                                        \
        TY d1_m2 = o_m2 + L97_A * (e_m2 + e_m1);                                                             \
        TY d1_m1 = o_m1 + L97_A * (e_m1 + e_0);                                                              \
        TY d1_0 = o_0 + L97_A * (e_0 + e_p1);                                                                \
        TY d1_p1 = o_p1 + L97_A * (e_p1 + e_p2);                                                             \
        TY s1_m1 = e_m1 + L97_B * (d1_m2 + d1_m1);                                                           \
        TY s1_0 = e_0 + L97_B * (d1_m1 + d1_0);                                                              \
        TY s1_p1 = e_p1 + L97_B * (d1_0 + d1_p1);                                                            \
        TY d2_m1 = d1_m1 + L97_G * (s1_m1 + s1_0);                                                           \
        TY d2_0 = d1_0 + L97_G * (s1_0 + s1_p1);                                                             \
        s_out = (s1_0 + L97_D * (d2_m1 + d2_0)) * (1.0f / L97_K);                                            \
        d_out = d2_0 * (0.5f * L97_K);                                                                       \
    }
#define INV_BODY(TY)                                                                                         \
    {                                                                                                        \
        TY s2_m1 = s_m1 * L97_K, s2_0 = s_0 * L97_K, s2_p1 = s_p1 * L97_K, s2_p2 = s_p2 * L97_K;             \
        TY d2_m2 = d_m2 * (2.0f / L97_K), d2_m1 = d_m1 * (2.0f / L97_K), d2_0 = d_0 * (2.0f / L97_K);        \
        TY d2_p1 = d_p1 * (2.0f / L97_K), d2_p2 = d_p2 * (2.0f / L97_K);                                     \
        TY s1_m1 = s2_m1 - L97_D * (d2_m2 + d2_m1);                                                          \
        TY s1_0 = s2_0 - L97_D * (d2_m1 + d2_0);                                                             \
        TY s1_p1 = s2_p1 - L97_D * (d2_0 + d2_p1);                                                           \
        TY s1_p2 = s2_p2 - L97_D * (d2_p1 + d2_p2);                                                          \
        TY d1_m1 = d2_m1 - L97_G * (s1_m1 + s1_0);                                                           \
        TY d1_0 = d2_0 - L97_G * (s1_0 + s1_p1);                                                             \
        TY d1_p1 = d2_p1 - L97_G * (s1_p1 + s1_p2);                                                          \
        TY e0 = s1_0 - L97_B * (d1_m1 + d1_0);                                                               \
        TY e1 = s1_p1 - L97_B * (d1_0 + d1_p1);                                                              \
        e_out = e0;                                                                                          \
        o_out = d1_0 - L97_A * (e0 + e1);                                                                    \
    }
#define WIN_FWD_E_LO (-2)
#define WIN_FWD_E_HI 2
#define WIN_FWD_O_LO (-2)
#define WIN_FWD_O_HI 1
#define WIN_INV_S_LO (-1)
#define WIN_INV_S_HI 2
#define WIN_INV_D_LO (-2)
#define WIN_INV_D_HI 2
#elif WAVELET == 2
#define FWD_BODY(TY)                                                                                         \
    {                                                                                                        \
        TY d0 = o_0 - e_0;                                                                                   \
        s_out = e_0 + HALF(d0);                                                                              \
        d_out = d0;                                                                                          \
    }
#define INV_BODY(TY)                                                                                         \
    {                                                                                                        \
        TY e0 = s_0 - HALF(d_0);                                                                             \
        e_out = e0;                                                                                          \
        o_out = d_0 + e0;                                                                                    \
    }
#define WIN_FWD_E_LO 0
#define WIN_FWD_E_HI 0
#define WIN_FWD_O_LO 0
#define WIN_FWD_O_HI 0
#define WIN_INV_S_LO 0
#define WIN_INV_S_HI 0
#define WIN_INV_D_LO 0
#define WIN_INV_D_HI 0
#else
/* 2/6: S-transform (Haar) pairs, then the high band is predicted from the slope of the low band. */
#define FWD_BODY(TY)                                                                                         \
    {                                                                                                        \
        TY d1_m1 = o_m1 - e_m1, d1_0 = o_0 - e_0, d1_p1 = o_p1 - e_p1;                                       \
        TY s_m1 = e_m1 + HALF(d1_m1);                                                                        \
        TY s_p1 = e_p1 + HALF(d1_p1);                                                                        \
        s_out = e_0 + HALF(d1_0);                                                                            \
        d_out = d1_0 + QUARTER_R(s_m1 - s_p1);                                                               \
    }
#define INV_BODY(TY)                                                                                         \
    {                                                                                                        \
        TY d1 = d_0 - QUARTER_R(s_m1 - s_p1);                                                                \
        TY e0 = s_0 - HALF(d1);                                                                              \
        e_out = e0;                                                                                          \
        o_out = d1 + e0;                                                                                     \
    }
#define WIN_FWD_E_LO (-1)
#define WIN_FWD_E_HI 1
#define WIN_FWD_O_LO (-1)
#define WIN_FWD_O_HI 1
#define WIN_INV_S_LO (-1)
#define WIN_INV_S_HI 1
#define WIN_INV_D_LO 0
#define WIN_INV_D_HI 0
#endif

/* Window loads: LOADER(name, k) declares `name` for pair offset k when k is inside the window. */
#define IN_WIN(k, lo, hi) ((k) >= (lo) && (k) <= (hi))

/* Lone last sample of Haar / 2/6 inverse: the pair had no odd sample, so the low coefficient is the
   sample (the detail was never stored). 5/3 and 9/7 reconstruct it through the symmetric extension. */
#if SYMMETRIC_EXTENSION
#define LONE_FIX(e_out, s_0)
#else
#define LONE_FIX(e_out, s_0) e_out = (s_0)-0
#endif

/* Shifted copies of a 16-lane vector: lanes move by one and `edge` fills the freed lane. The x passes
   build their neighbour windows this way from two aligned loads instead of loading at odd offsets. */
inline V shift_up(V x, T next) {
    return shuffle2(x, (V)(next), (uint16)(1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16));
}
inline V shift_down(V x, T prev) {
    return shuffle2(x, (V)(prev), (uint16)(16, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14));
}

/* y/z passes: work-item (gid0, gid1, brick) with gid0 = x chunk + chunks * a. For y, a = pair and gid1 = z;
   for z, a = y and gid1 = pair, so neighbouring work-items touch neighbouring 64-byte rows of one plane. */
#define YZ_COORDS()                                                                                          \
    const int chunks = ((int)nx + 15) >> 4;                                                                  \
    const int g0 = get_global_id(0);                                                                         \
    const int chunk = g0 % chunks;                                                                           \
    const int ga = g0 / chunks;                                                                              \
    const int gb = get_global_id(1);                                                                         \
    const int c = get_global_id(2);                                                                          \
    const int pair = axis == 1 ? ga : gb;                                                                    \
    const int o = axis == 1 ? gb : ga;

#ifndef LIFT_INVERSE

/* ---------------------------------------------------------------- forward */

/* x pass: one work-item makes 16 consecutive (low, high) pairs of one row. */
kernel void lift_x(global const T* src, global T* dst, uint px, uint by, uint bz, uint nx, uint ny, uint nz,
                   uint count) {
    const int chunk = get_global_id(0);
    const int y = get_global_id(1);
    const int g = get_global_id(2);
    const int N = nx;
    const int ms = (N + 1) >> 1, md = N >> 1;
    if (y >= (int)ny || g >= (int)(count * nz) || chunk * 16 >= ms) return;
    const int c = g / nz, z = g % nz;
    const size_t row = ((size_t)(c * bz + z) * by + y) * px;
    global const T* in = src + row;
    global T* out = dst + row;
    const int n0 = chunk * 16;
    if (N == 1) {
        out[0] = in[0];
        return;
    }
    if (2 * n0 + 32 <= N) {
        /* 16 whole pairs: two aligned loads; the neighbours are shifted copies plus a few scalar samples
           fetched through the extension (mirror or clamp), as in the staged path below. */
        V a = vload16(0, in + 2 * n0), b = vload16(0, in + 2 * n0 + 16);
        V e_0 = (V)(a.even, b.even), o_0 = (V)(a.odd, b.odd);
        V e_m2 = 0, e_m1 = 0, e_p1 = 0, e_p2 = 0, o_m2 = 0, o_m1 = 0, o_p1 = 0;
        if (IN_WIN(-1, WIN_FWD_E_LO, WIN_FWD_E_HI)) e_m1 = shift_down(e_0, in[even_pos(n0 - 1, N)]);
        if (IN_WIN(-2, WIN_FWD_E_LO, WIN_FWD_E_HI)) e_m2 = shift_down(e_m1, in[even_pos(n0 - 2, N)]);
        if (IN_WIN(1, WIN_FWD_E_LO, WIN_FWD_E_HI)) e_p1 = shift_up(e_0, in[even_pos(n0 + 16, N)]);
        if (IN_WIN(2, WIN_FWD_E_LO, WIN_FWD_E_HI)) e_p2 = shift_up(e_p1, in[even_pos(n0 + 17, N)]);
        if (IN_WIN(-1, WIN_FWD_O_LO, WIN_FWD_O_HI)) o_m1 = shift_down(o_0, in[odd_pos(n0 - 1, N)]);
        if (IN_WIN(-2, WIN_FWD_O_LO, WIN_FWD_O_HI)) o_m2 = shift_down(o_m1, in[odd_pos(n0 - 2, N)]);
        if (IN_WIN(1, WIN_FWD_O_LO, WIN_FWD_O_HI)) o_p1 = shift_up(o_0, in[odd_pos(n0 + 16, N)]);
        V s_out, d_out;
        FWD_BODY(V)
        vstore16(s_out, 0, out + n0);
        vstore16(d_out, 0, out + ms + n0);
        return;
    }
    /* Line ends: stage pairs n0-2 .. n0+17 (extension applied) in private memory, then the same vector code. */
    T buf[40];
    for (int j = 0; j < 40; ++j) {
        const int m = n0 - 2 + (j >> 1);
        buf[j] = in[(j & 1) ? odd_pos(m, N) : even_pos(m, N)];
    }
    V e_m2 = 0, e_m1 = 0, e_0, e_p1 = 0, e_p2 = 0, o_m2 = 0, o_m1 = 0, o_0, o_p1 = 0, unused;
#define LD_STAGED(k, E, O)                                                                                   \
    {                                                                                                        \
        V a = vload16(0, buf + 2 * ((k) + 2));                                                               \
        V b = vload16(0, buf + 2 * ((k) + 2) + 16);                                                          \
        E = (V)(a.even, b.even);                                                                             \
        O = (V)(a.odd, b.odd);                                                                               \
    }
    if (IN_WIN(-2, WIN_FWD_E_LO, WIN_FWD_E_HI)) LD_STAGED(-2, e_m2, o_m2);
    if (IN_WIN(-1, WIN_FWD_E_LO, WIN_FWD_E_HI)) LD_STAGED(-1, e_m1, o_m1);
    LD_STAGED(0, e_0, o_0);
    if (IN_WIN(1, WIN_FWD_E_LO, WIN_FWD_E_HI)) LD_STAGED(1, e_p1, o_p1);
    if (IN_WIN(2, WIN_FWD_E_LO, WIN_FWD_E_HI)) LD_STAGED(2, e_p2, unused);
#undef LD_STAGED
    V s_out, d_out;
    FWD_BODY(V)
    T sa[16], da[16];
    vstore16(s_out, 0, sa);
    vstore16(d_out, 0, da);
    for (int i = 0; i < 16 && n0 + i < ms; ++i) {
        out[n0 + i] = sa[i];
        if (n0 + i < md) out[ms + n0 + i] = da[i];
    }
}

/* y or z pass: one work-item makes one (low, high) pair for 16 consecutive x. */
kernel void lift_yz(global const T* src, global T* dst, uint px, uint by, uint bz, uint nx, uint ny, uint nz,
                    uint count, uint axis) {
    YZ_COORDS()
    const int N = axis == 1 ? ny : nz;
    const int other = axis == 1 ? nz : ny;
    const int ms = (N + 1) >> 1, md = N >> 1;
    if (pair >= ms || o >= other || c >= (int)count) return;
    const size_t stride = axis == 1 ? (size_t)px : (size_t)px * by;
    const size_t base = axis == 1 ? ((size_t)(c * bz + o) * by) * px : ((size_t)(c * bz) * by + o) * px;
    global const T* in = src + base + chunk * 16;
    global T* out = dst + base + chunk * 16;
    const bool full = chunk * 16 + 16 <= (int)nx;
    if (N == 1) {
        if (full) {
            vstore16(vload16(0, in), 0, out);
        } else {
            for (int i = chunk * 16; i < (int)nx; ++i)
                out[i - chunk * 16] = in[i - chunk * 16];
        }
        return;
    }
    V e_m2 = 0, e_m1 = 0, e_0, e_p1 = 0, e_p2 = 0, o_m2 = 0, o_m1 = 0, o_0, o_p1 = 0;
    if (IN_WIN(-2, WIN_FWD_E_LO, WIN_FWD_E_HI)) e_m2 = vload16(0, in + even_pos(pair - 2, N) * stride);
    if (IN_WIN(-1, WIN_FWD_E_LO, WIN_FWD_E_HI)) e_m1 = vload16(0, in + even_pos(pair - 1, N) * stride);
    e_0 = vload16(0, in + even_pos(pair, N) * stride);
    if (IN_WIN(1, WIN_FWD_E_LO, WIN_FWD_E_HI)) e_p1 = vload16(0, in + even_pos(pair + 1, N) * stride);
    if (IN_WIN(2, WIN_FWD_E_LO, WIN_FWD_E_HI)) e_p2 = vload16(0, in + even_pos(pair + 2, N) * stride);
    if (IN_WIN(-2, WIN_FWD_O_LO, WIN_FWD_O_HI)) o_m2 = vload16(0, in + odd_pos(pair - 2, N) * stride);
    if (IN_WIN(-1, WIN_FWD_O_LO, WIN_FWD_O_HI)) o_m1 = vload16(0, in + odd_pos(pair - 1, N) * stride);
    o_0 = vload16(0, in + odd_pos(pair, N) * stride);
    if (IN_WIN(1, WIN_FWD_O_LO, WIN_FWD_O_HI)) o_p1 = vload16(0, in + odd_pos(pair + 1, N) * stride);
    V s_out, d_out;
    FWD_BODY(V)
    global T* ps = out + pair * stride;
    global T* pd = out + (ms + pair) * stride;
    if (full) {
        vstore16(s_out, 0, ps);
        if (pair < md) vstore16(d_out, 0, pd);
    } else {
        /* keep coefficients of earlier levels that sit right of the active columns */
        T sa[16], da[16];
        vstore16(s_out, 0, sa);
        vstore16(d_out, 0, da);
        for (int i = 0; i < (int)nx - chunk * 16; ++i) {
            ps[i] = sa[i];
            if (pair < md) pd[i] = da[i];
        }
    }
}

#else

/* ---------------------------------------------------------------- inverse */

kernel void lift_x(global const T* src, global T* dst, uint px, uint by, uint bz, uint nx, uint ny, uint nz,
                   uint count) {
    const int chunk = get_global_id(0);
    const int y = get_global_id(1);
    const int g = get_global_id(2);
    const int N = nx;
    const int ms = (N + 1) >> 1, md = N >> 1;
    if (y >= (int)ny || g >= (int)(count * nz) || chunk * 16 >= ms) return;
    const int c = g / nz, z = g % nz;
    const size_t row = ((size_t)(c * bz + z) * by + y) * px;
    global const T* in = src + row;
    global T* out = dst + row;
    const int n0 = chunk * 16;
    if (N == 1) {
        out[0] = in[0];
        return;
    }
    if (2 * n0 + 32 <= N) {
        /* 16 whole pairs: aligned loads of s and d, neighbours as shifted copies (see the forward pass). */
        V s_0 = vload16(0, in + n0), d_0 = vload16(0, in + ms + n0);
        V s_m1 = 0, s_p1 = 0, s_p2 = 0, d_m2 = 0, d_m1 = 0, d_p1 = 0, d_p2 = 0;
        if (IN_WIN(-1, WIN_INV_S_LO, WIN_INV_S_HI)) s_m1 = shift_down(s_0, in[low_pos(n0 - 1, N)]);
        if (IN_WIN(1, WIN_INV_S_LO, WIN_INV_S_HI)) s_p1 = shift_up(s_0, in[low_pos(n0 + 16, N)]);
        if (IN_WIN(2, WIN_INV_S_LO, WIN_INV_S_HI)) s_p2 = shift_up(s_p1, in[low_pos(n0 + 17, N)]);
        if (IN_WIN(-1, WIN_INV_D_LO, WIN_INV_D_HI)) d_m1 = shift_down(d_0, in[ms + high_pos(n0 - 1, N)]);
        if (IN_WIN(-2, WIN_INV_D_LO, WIN_INV_D_HI)) d_m2 = shift_down(d_m1, in[ms + high_pos(n0 - 2, N)]);
        if (IN_WIN(1, WIN_INV_D_LO, WIN_INV_D_HI)) d_p1 = shift_up(d_0, in[ms + high_pos(n0 + 16, N)]);
        if (IN_WIN(2, WIN_INV_D_LO, WIN_INV_D_HI)) d_p2 = shift_up(d_p1, in[ms + high_pos(n0 + 17, N)]);
        V e_out, o_out;
        INV_BODY(V)
        vstore16(shuffle2(e_out, o_out, (uint16)(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23)), 0,
                 out + 2 * n0);
        vstore16(
            shuffle2(e_out, o_out, (uint16)(8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31)), 0,
            out + 2 * n0 + 16);
        return;
    }
    /* Line ends: stage coefficients of pairs n0-2 .. n0+17 (extension applied), then the vector code. */
    T sbuf[20], dbuf[20];
    for (int j = 0; j < 20; ++j) {
        const int m = n0 - 2 + j;
        sbuf[j] = in[low_pos(m, N)];
        dbuf[j] = (SYMMETRIC_EXTENSION || (m >= 0 && 2 * m + 1 < N)) ? in[ms + high_pos(m, N)] : 0;
    }
    V s_m1 = vload16(0, sbuf + 1), s_0 = vload16(0, sbuf + 2), s_p1 = vload16(0, sbuf + 3),
      s_p2 = vload16(0, sbuf + 4);
    V d_m2 = vload16(0, dbuf), d_m1 = vload16(0, dbuf + 1), d_0 = vload16(0, dbuf + 2),
      d_p1 = vload16(0, dbuf + 3);
    V d_p2 = vload16(0, dbuf + 4);
    V e_out, o_out;
    INV_BODY(V)
    T ea[16], oa[16], sa[16];
    vstore16(e_out, 0, ea);
    vstore16(o_out, 0, oa);
    vstore16(s_0, 0, sa);
    for (int i = 0; i < 16 && n0 + i < ms; ++i) {
        const int pair = n0 + i;
        if (2 * pair + 1 < N) {
            out[2 * pair + 1] = oa[i];
            out[2 * pair] = ea[i];
        } else {
            out[2 * pair] = SYMMETRIC_EXTENSION ? ea[i] : sa[i];
        }
    }
}

kernel void lift_yz(global const T* src, global T* dst, uint px, uint by, uint bz, uint nx, uint ny, uint nz,
                    uint count, uint axis) {
    YZ_COORDS()
    const int N = axis == 1 ? ny : nz;
    const int other = axis == 1 ? nz : ny;
    const int ms = (N + 1) >> 1;
    if (pair >= ms || o >= other || c >= (int)count) return;
    const size_t stride = axis == 1 ? (size_t)px : (size_t)px * by;
    const size_t base = axis == 1 ? ((size_t)(c * bz + o) * by) * px : ((size_t)(c * bz) * by + o) * px;
    global const T* in = src + base + chunk * 16;
    global T* out = dst + base + chunk * 16;
    const bool full = chunk * 16 + 16 <= (int)nx;
    if (N == 1) {
        if (full) {
            vstore16(vload16(0, in), 0, out);
        } else {
            for (int i = chunk * 16; i < (int)nx; ++i)
                out[i - chunk * 16] = in[i - chunk * 16];
        }
        return;
    }
    V s_m1 = 0, s_0, s_p1 = 0, s_p2 = 0, d_m2 = 0, d_m1 = 0, d_0 = 0, d_p1 = 0, d_p2 = 0;
    if (IN_WIN(-1, WIN_INV_S_LO, WIN_INV_S_HI)) s_m1 = vload16(0, in + low_pos(pair - 1, N) * stride);
    s_0 = vload16(0, in + low_pos(pair, N) * stride);
    if (IN_WIN(1, WIN_INV_S_LO, WIN_INV_S_HI)) s_p1 = vload16(0, in + low_pos(pair + 1, N) * stride);
    if (IN_WIN(2, WIN_INV_S_LO, WIN_INV_S_HI)) s_p2 = vload16(0, in + low_pos(pair + 2, N) * stride);
    if (IN_WIN(-2, WIN_INV_D_LO, WIN_INV_D_HI)) d_m2 = vload16(0, in + (ms + high_pos(pair - 2, N)) * stride);
    if (IN_WIN(-1, WIN_INV_D_LO, WIN_INV_D_HI)) d_m1 = vload16(0, in + (ms + high_pos(pair - 1, N)) * stride);
    if (SYMMETRIC_EXTENSION || 2 * pair + 1 < N) d_0 = vload16(0, in + (ms + high_pos(pair, N)) * stride);
    if (IN_WIN(1, WIN_INV_D_LO, WIN_INV_D_HI)) d_p1 = vload16(0, in + (ms + high_pos(pair + 1, N)) * stride);
    if (IN_WIN(2, WIN_INV_D_LO, WIN_INV_D_HI)) d_p2 = vload16(0, in + (ms + high_pos(pair + 2, N)) * stride);
    V e_out, o_out;
    INV_BODY(V)
    const bool hasOdd = 2 * pair + 1 < N;
    if (!hasOdd) LONE_FIX(e_out, s_0);
    global T* pe = out + (2 * pair) * stride;
    global T* po = out + (2 * pair + 1) * stride;
    if (full) {
        vstore16(e_out, 0, pe);
        if (hasOdd) vstore16(o_out, 0, po);
    } else {
        T ea[16], oa[16];
        vstore16(e_out, 0, ea);
        vstore16(o_out, 0, oa);
        for (int i = 0; i < (int)nx - chunk * 16; ++i) {
            pe[i] = ea[i];
            if (hasOdd) po[i] = oa[i];
        }
    }
}

#endif

/* Copies the active corner (nx, ny, nz) of every brick from src to dst (merging a level's result back). */
kernel void copy_corner(global const T* src, global T* dst, uint px, uint by, uint bz, uint nx, uint ny,
                        uint nz, uint count) {
    const int x = get_global_id(0);
    const int y = get_global_id(1);
    const int g = get_global_id(2);
    if (x >= (int)nx || y >= (int)ny || g >= (int)(count * nz)) return;
    const int c = g / nz, z = g % nz;
    const size_t i = ((size_t)(c * bz + z) * by + y) * px + x;
    dst[i] = src[i];
}
