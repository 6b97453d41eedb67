/* Iso-surface hits on a cubic B-spline field (included by raymarch.cl under FILTER_BSPLINE): sign changes
   between march samples, refined on the spline. */
#if ISO_COUNT > 0 && defined(FILTER_BSPLINE)
/* Along a ray the spline is a piecewise polynomial of degree 9, so the trilinear cell walk of
   raymarch_iso.h does not apply: a crossing is a change of side (s >= iso or s < iso, as there) between
   the march's samples at t0 and t1, refined by regula falsi with the Illinois modification (superlinear,
   bracket kept) to ISO_SAMPLED_TOL_VOXELS along the ray. Two crossings inside one step cancel: the step
   bounds the thinnest shell that shows. */
#define ISO_SAMPLED_TOL_VOXELS 1e-4f
#define ISO_SAMPLED_MAX_ITER 30

inline float iso_sampled_root(__global const voxel_t* vol, const VolclGridRenderParams* P, const Ray* r,
                              float iso, float ta, float fa, float tb, float fb, float tol) {
    int lastSide = 0; /* which end moved last: -1 a, +1 b */
    for (int it = 0; it < ISO_SAMPLED_MAX_ITER && tb - ta > tol; ++it) {
        float t = fb != fa ? ta - fa * (tb - ta) / (fb - fa) : 0.5f * (ta + tb);
        if (!(t > ta && t < tb)) t = 0.5f * (ta + tb);
        const float f = sample_volume(vol, &P->grid, ray_at(r, t)) - iso;
        if ((f >= 0.0f) == (fa >= 0.0f)) {
            ta = t;
            fa = f;
            if (lastSide == -1) fb *= 0.5f; /* Illinois: the stale end's weight halves */
            lastSide = -1;
        } else {
            tb = t;
            fb = f;
            if (lastSide == 1) fa *= 0.5f;
            lastSide = 1;
        }
    }
    return 0.5f * (ta + tb);
}

/* Composites the iso-surfaces whose side differs between the samples s0 at t0 and s1 at t1, in ray order. */
inline void iso_sampled_segment(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                                const VolclGridRenderParams* P, const Ray* r, float t0, float s0, float t1,
                                float s1, float3* rgb, float* T, float* depth SHADOW_PARAMS) {
    if (!(*T > 0.0f)) return; /* behind an opaque surface nothing more shows */
    float th[ISO_COUNT];
    int order[ISO_COUNT];
    int n = 0;
    const float tol = ISO_SAMPLED_TOL_VOXELS / length(r->d);
    for (int i = 0; i < ISO_COUNT; ++i) {
        const float iso = P->iso.value[i];
        if ((s0 >= iso) == (s1 >= iso)) continue;
        th[n] = iso_sampled_root(vol, P, r, iso, t0, s0 - iso, t1, s1 - iso, tol);
        order[n] = i;
        ++n;
    }
    if (n) iso_composite(vol, knots, P, r, th, order, n, rgb, T, depth SHADOW_ARGS);
}
#endif
