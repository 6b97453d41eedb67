/* Lifting definitions shared by the streaming pass kernels (lifting.cl) and the brick-resident kernel
   (lifting_brick.cl): element types, rounding, the 9/7 constants and the extension rules.

   Specialised with -D:
     WAVELET    0 = CDF 5/3, 1 = CDF 9/7, 2 = Haar, 3 = CDF 2/6 (Guthe's "2/6", the TS transform)
     LIFT_FLOAT defined: float arithmetic (lossy path); otherwise int with floor rounding (reversible)
     LIFT_INVERSE defined: synthesis; otherwise analysis

   Extension: 5/3 and 9/7 use whole-sample symmetric extension of the signal (no extra coefficients);
   Haar and 2/6 pair samples (2m, 2m+1); a lone last sample passes through as a low coefficient and
   the 2/6 update clamps its neighbour index to the valid low coefficients. */

#ifdef LIFT_FLOAT
typedef float T;
typedef float16 V;
#define HALF(a) ((a)*0.5f)
#define QUARTER_R(a) ((a)*0.25f)
#else
typedef int T;
typedef int16 V;
#define HALF(a) ((a) >> 1)
#define QUARTER_R(a) (((a) + 2) >> 2)
#endif

#if WAVELET == 0 || WAVELET == 1
#define SYMMETRIC_EXTENSION 1
#else
#define SYMMETRIC_EXTENSION 0
#endif

/* CDF 9/7 lifting constants (Daubechies & Sweldens 1998) and the scaling that gives the low band DC gain 1. */
#define L97_A (-1.586134342059924f)
#define L97_B (-0.052980118572961f)
#define L97_G (0.882911075530934f)
#define L97_D (0.443506852043971f)
#define L97_K (1.230174104914001f)

/* Whole-sample symmetric reflection of index i into [0, n), n >= 2; keeps the parity of i. */
inline int mirror_index(int i, int n) {
    if ((uint)i < (uint)n) return i; /* the common case, without the division below */
    int p = 2 * (n - 1);
    /* one reflection: every margin of a line longer than the lifting window, still without a division */
    if (i < 0 && -i < n) return -i;
    if (i >= n && i <= p) return p - i;
    i = i % p;
    if (i < 0) i += p;
    return i < n ? i : p - i;
}

/* Position in the signal of the even / odd sample of pair m under the wavelet's extension. */
inline int even_pos(int m, int n) {
#if SYMMETRIC_EXTENSION
    return mirror_index(2 * m, n);
#else
    int ms = (n + 1) >> 1;
    return 2 * clamp(m, 0, ms - 1);
#endif
}
inline int odd_pos(int m, int n) {
#if SYMMETRIC_EXTENSION
    return mirror_index(2 * m + 1, n);
#else
    /* a lone last sample pairs with itself, which gives a zero detail */
    int ms = (n + 1) >> 1;
    int k = clamp(m, 0, ms - 1);
    return 2 * k + 1 < n ? 2 * k + 1 : 2 * k;
#endif
}
/* Index into the low (s) / high (d) half of a transformed line for pair m. */
inline int low_pos(int m, int n) {
#if SYMMETRIC_EXTENSION
    return mirror_index(2 * m, n) >> 1;
#else
    return clamp(m, 0, ((n + 1) >> 1) - 1);
#endif
}
inline int high_pos(int m, int n) {
#if SYMMETRIC_EXTENSION
    return mirror_index(2 * m + 1, n) >> 1;
#else
    return clamp(m, 0, (n >> 1) - 1);
#endif
}
