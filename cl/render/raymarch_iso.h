/* Iso-surface hits for the ray marcher (included by raymarch.cl): exact roots of the trilinear cubic per cell. */
#if ISO_COUNT > 0
/* Along a ray through one voxel cell the trilinear field is a cubic in t (Marmitt et al. 2004, Parker et al.
   1998). The ray is walked cell by cell (3D DDA), each cell's cubic is split at the real roots of its
   derivative into monotone pieces, and every piece whose ends lie on different sides of an iso-value holds
   exactly one crossing, which is refined there. Unlike a sign test between two samples this also finds two
   crossings inside one step (thin shells, grazing hits). A side is s >= iso ("inside") or s < iso, the
   sign test of the planner and the macrocells; the side is carried from cell to cell, so a crossing that
   rounding places exactly on a cell face is neither lost nor counted twice. */

/* A root is refined until the last Newton or bisection correction is below this many voxels (along the
   ray); a Newton correction that small leaves an error of its square, a bisection one a bracket half as
   wide, so the hit is well inside the 1e-4 voxel goal. */
#define ISO_TOL_VOXELS 1e-5f
#define ISO_MAX_ITER 24

typedef struct {
    int3 cell;     /* current cell (lower corner), in the DDA's own index space (may pass the grid by one) */
    float3 tNext;  /* ray parameter where the ray leaves the cell through each axis' face */
    float3 tDelta; /* ray parameter per cell along each axis */
    int3 dir;      /* -1, 0, +1 per axis */
    float tOut;    /* min(tNext): where the ray leaves the current cell */
    float8 v;      /* corner values v000 v100 v010 v110 v001 v101 v011 v111 (x fastest) */
    float3 base;   /* lower corner of the cell the values belong to (the DDA cell clamped to the grid) */
    uint cubic;    /* bit i: iso_i in (min, max] of the corners (the field lies between them): may cross */
    uint side0;    /* bit i: iso_i <= min, the side of the whole cell for isos not in cubic */
    float3 invD;   /* 1 / direction */
    float3 o;      /* ray origin (voxel coordinates) */
    uint inside;   /* bit i: s >= iso_i where the last piece ended */
    int started;   /* 0 until the first piece sets the sides */
#ifdef NAN_COLOR
    int nonFinite; /* the cell has a corner that is not finite: it holds no crossing */
#endif
} IsoState;

inline void iso_begin(IsoState* st, const Ray* r) {
    st->tOut = -INFINITY;
    st->inside = 0u;
    st->started = 0;
    st->dir = select(select((int3)(0), (int3)(1), r->d > 0.0f), (int3)(-1), r->d < 0.0f);
    st->invD = 1.0f / r->d;
    st->o = r->o;
    st->tDelta = select(fabs(st->invD), (float3)(INFINITY), r->d == 0.0f);
}

#ifndef VOLCL_BRICK_SAMPLE_H
/* The grid's values at the corners of the cell from node c0 to c1 (v000 v100 v010 v110 v001 v101 v011
   v111, x fastest). The brick marcher's sampler (common/brick_sample.h) provides its own: there `vol` is
   the brick pool, not a grid. */
inline float8 cell_corners(__global const voxel_t* vol, const VolclGridParams* G, int3 c0, int3 c1) {
    const uint nx = G->dims[0], nxy = G->dims[0] * G->dims[1];
    const uint z0 = (uint)c0.z * nxy, z1 = (uint)c1.z * nxy, y0 = (uint)c0.y * nx, y1 = (uint)c1.y * nx;
    float2 a00 = convert_float2(vload2(0, vol + z0 + y0 + c0.x));
    float2 a10 = convert_float2(vload2(0, vol + z0 + y1 + c0.x));
    float2 a01 = convert_float2(vload2(0, vol + z1 + y0 + c0.x));
    float2 a11 = convert_float2(vload2(0, vol + z1 + y1 + c0.x));
    if (nx == 1u) { /* the second value of each pair is the buffer's spare voxel: no x variation */
        a00.y = a00.x;
        a10.y = a10.x;
        a01.y = a01.x;
        a11.y = a11.x;
    }
    return (float8)(a00, a10, a01, a11);
}
#endif

/* Loads the corners of the DDA's cell (clamped to the grid) and classifies the iso-values against them. */
inline void iso_load_cell(__global const voxel_t* vol, const VolclGridRenderParams* P, IsoState* st) {
    const int3 hiI = (int3)((int)P->grid.dims[0] - 1, (int)P->grid.dims[1] - 1, (int)P->grid.dims[2] - 1);
    const int3 c0 = clamp(st->cell, (int3)(0), max(hiI - 1, (int3)(0)));
    const int3 c1 = min(c0 + 1, hiI);
    st->base = convert_float3(c0);
    st->v = cell_corners(vol, &P->grid, c0, c1);
    const float4 mn4 = fmin(st->v.lo, st->v.hi), mx4 = fmax(st->v.lo, st->v.hi);
    const float2 mn2 = fmin(mn4.lo, mn4.hi), mx2 = fmax(mx4.lo, mx4.hi);
    const float lo = fmin(mn2.x, mn2.y), hi = fmax(mx2.x, mx2.y);
    uint cubic = 0u, side0 = 0u;
    for (int i = 0; i < ISO_COUNT; ++i) {
        const float iso = P->iso.value[i];
        cubic |= (lo < iso && iso <= hi) ? 1u << i : 0u;
        side0 |= iso <= lo ? 1u << i : 0u;
    }
#ifdef NAN_COLOR
    /* fmin/fmax skip NaN, so lo/hi alone would classify the cell by its finite corners. */
    st->nonFinite = !(isfinite(lo) && isfinite(hi)) || any(isnan(st->v.lo)) || any(isnan(st->v.hi));
    if (st->nonFinite) cubic = side0 = 0u;
#endif
    st->cubic = cubic;
    st->side0 = side0;
}

/* True when the piece can hold a crossing or the sides are not set yet; false for a cell entirely on the
   sides the ray already carries (most cells: no corner loads beyond the cell's own, no cubic). */
inline int iso_piece_needed(const IsoState* st) {
#ifdef NAN_COLOR
    if (st->nonFinite) return 1; /* iso_piece forgets the sides there */
#endif
    return st->cubic != 0u || !st->started || ((st->side0 ^ st->inside) & ((1u << ISO_COUNT) - 1u)) != 0u;
}

inline float iso_tout(float3 tn) {
    return fmin(tn.x, fmin(tn.y, tn.z));
}

/* Moves the DDA across the nearest cell face (ties: x, then y, then z). The new face's ray parameter is
   computed from the cell, as iso_locate computes it, not accumulated: a cell's pieces, and so its roots, are
   then the same bits whether the walk stepped into the cell or was relocated there after skipped space (the
   grid and brick marchers skip different macrocells and must still find the same hits). */
inline void iso_cross_face(IsoState* st) {
    const float3 tn = st->tNext;
    if (tn.x <= tn.y && tn.x <= tn.z) {
        st->cell.x += st->dir.x;
        st->tNext.x = ((float)(st->cell.x + (st->dir.x > 0 ? 1 : 0)) - st->o.x) * st->invD.x;
    } else if (tn.y <= tn.z) {
        st->cell.y += st->dir.y;
        st->tNext.y = ((float)(st->cell.y + (st->dir.y > 0 ? 1 : 0)) - st->o.y) * st->invD.y;
    } else {
        st->cell.z += st->dir.z;
        st->tNext.z = ((float)(st->cell.z + (st->dir.z > 0 ? 1 : 0)) - st->o.z) * st->invD.z;
    }
}

/* Puts the DDA in the cell the ray occupies just after t (a ray leaving a face downward belongs to the lower
   cell), then steps past cells that float rounding says it has already left. */
inline void iso_locate(__global const voxel_t* vol, const VolclGridRenderParams* P, const Ray* r, float t,
                       IsoState* st) {
    const float3 p = ray_at(r, t);
    const int3 hiI = (int3)((int)P->grid.dims[0] - 1, (int)P->grid.dims[1] - 1, (int)P->grid.dims[2] - 1);
    int3 c = select(convert_int3(floor(p)), convert_int3(ceil(p)) - 1, r->d < 0.0f);
    c = clamp(c, (int3)(0), max(hiI - 1, (int3)(0)));
    const float3 face = convert_float3(c + select((int3)(0), (int3)(1), r->d > 0.0f));
    st->cell = c;
    st->tNext = select((face - r->o) * st->invD, (float3)(INFINITY), r->d == 0.0f);
    /* rounding can leave p a hair behind a face the ray has crossed: at most one cell per axis */
    for (int s = 0; s < 3 && iso_tout(st->tNext) <= t; ++s) {
        iso_cross_face(st);
    }
    st->tOut = iso_tout(st->tNext);
    iso_load_cell(vol, P, st);
}

/* One DDA step into the next cell. */
inline void iso_step(__global const voxel_t* vol, const VolclGridRenderParams* P, IsoState* st) {
    iso_cross_face(st);
    st->tOut = iso_tout(st->tNext);
    iso_load_cell(vol, P, st);
}

inline float iso_cubic(float4 c, float u) {
    return ((c.x * u + c.y) * u + c.z) * u + c.w;
}

/* The one crossing of a monotone piece [ua, ub] of cubic c, where side(ua) = sa != side(ub): safeguarded
   Newton (Numerical Recipes' rtsafe) keeping a bracket; a Newton step leaving the bracket or not halving
   the last correction is replaced by bisection. Stops when the correction is below tol. */
inline float iso_refine(float4 c, float iso, float ua, float ub, int sa, float tol) {
    const float3 dc = (float3)(3.0f * c.x, 2.0f * c.y, c.z);
    float lo = ua, hi = ub;
    const float fa = iso_cubic(c, ua) - iso, fb = iso_cubic(c, ub) - iso;
    /* start at the secant point, which is exact for a linear field */
    float x = fb != fa ? ua - fa * (ub - ua) / (fb - fa) : 0.5f * (ua + ub);
    x = fmin(fmax(x, ua), ub);
    float dxOld = ub - ua, dx = dxOld;
    for (int it = 0; it < ISO_MAX_ITER; ++it) {
        const float f = iso_cubic(c, x) - iso;
        const float df = (dc.x * x + dc.y) * x + dc.z;
        if ((f >= 0.0f) == (sa != 0))
            lo = x;
        else
            hi = x;
        const float xn = x - f / df;
        if (!(xn > fmin(lo, hi) && xn < fmax(lo, hi)) || fabs(2.0f * f) > fabs(dxOld * df)) {
            dxOld = dx;
            dx = 0.5f * (hi - lo);
            x = lo + dx;
        } else {
            dxOld = dx;
            dx = x - xn;
            x = xn;
        }
        if (fabs(dx) < tol) break;
    }
    return x;
}

/* Composites n hits (ray parameters th, iso indices order) in the given order. */
inline void iso_composite(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                          const VolclGridRenderParams* P, const Ray* r, float* th, int* order, int n,
                          float3* rgb, float* T, float* depth SHADOW_PARAMS) {
    for (int a = 1; a < n; ++a) /* insertion sort by hit distance */
        for (int b = a; b > 0 && th[b] < th[b - 1]; --b) {
            const float tt = th[b];
            th[b] = th[b - 1];
            th[b - 1] = tt;
            const int oo = order[b];
            order[b] = order[b - 1];
            order[b - 1] = oo;
        }
    for (int a = 0; a < n; ++a) {
        const int i = order[a];
        const float alpha = P->iso.color[i][3];
        float3 c = v3(P->iso.color[i]);
#ifdef NEEDS_LIGHTS
        c = light_sample(vol, knots, P, r, r->oWorld + th[a] * r->dWorld, ray_at(r, th[a]), c SHADOW_ARGS);
#endif
        if (isinf(*depth)) *depth = th[a];
        *rgb += *T * alpha * c;
        *T *= 1.0f - alpha;
    }
}

/* Hits of every iso-value on the piece [ta, tb] of the ray inside the current cell, composited in order. */
inline void iso_piece(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                      const VolclGridRenderParams* P, const Ray* r, IsoState* st, float ta, float tb,
                      float3* rgb, float* T, float* depth SHADOW_PARAMS) {
#ifdef NAN_COLOR
    /* No crossing in a cell with a corner that is not finite, nor on its faces: the sides start afresh in
       the next finite cell. */
    if (st->nonFinite) {
        st->started = 0;
        return;
    }
#endif
    float th[ISO_COUNT];
    int order[ISO_COUNT];
    int n = 0;
    const uint cubic = st->cubic, side0 = st->side0;
    float4 c = (float4)(0.0f);
    float u[4] = {0.0f, 0.0f, 0.0f, tb - ta};
    float g[4] = {0.0f, 0.0f, 0.0f, 0.0f};
    if (cubic) {
        /* The cubic in u = t - ta from the trilinear coefficients at a = p(ta) - cell, direction d. */
        const float3 a = ray_at(r, ta) - st->base;
        const float3 d = r->d;
        /* trilinear coefficients: k0 + kx x + ky y + kz z + kxy xy + kxz xz + kyz yz + kxyz xyz */
        const float8 v = st->v;
        float k[8];
        k[0] = v.s0;
        k[1] = v.s1 - v.s0;
        k[2] = v.s2 - v.s0;
        k[3] = v.s4 - v.s0;
        k[4] = (v.s3 - v.s2) - (v.s1 - v.s0);
        k[5] = (v.s5 - v.s4) - (v.s1 - v.s0);
        k[6] = (v.s6 - v.s4) - (v.s2 - v.s0);
        k[7] = ((v.s7 - v.s6) - (v.s5 - v.s4)) - ((v.s3 - v.s2) - (v.s1 - v.s0));
        const float ex = k[1] + k[4] * a.y + k[5] * a.z + k[7] * a.y * a.z; /* df/dx at a */
        const float ey = k[2] + k[4] * a.x + k[6] * a.z + k[7] * a.x * a.z;
        const float ez = k[3] + k[5] * a.x + k[6] * a.y + k[7] * a.x * a.y;
        const float fxy = k[4] + k[7] * a.z, fxz = k[5] + k[7] * a.y, fyz = k[6] + k[7] * a.x;
        c.x = k[7] * d.x * d.y * d.z;
        c.y = fxy * d.x * d.y + fxz * d.x * d.z + fyz * d.y * d.z;
        c.z = ex * d.x + ey * d.y + ez * d.z;
        c.w = k[0] + k[1] * a.x + (k[2] + k[4] * a.x) * a.y +
              (k[3] + k[5] * a.x + (k[6] + k[7] * a.x) * a.y) * a.z;
        /* Roots of the derivative 3 c.x u^2 + 2 c.y u + c.z, the stable way; NaN and out-of-range roots fall
           on the piece ends (fmax/fmin return the number when the other operand is NaN). */
        const float disc = c.y * c.y - 3.0f * c.x * c.z;
        const float q = -(c.y + copysign(sqrt(fmax(disc, 0.0f)), c.y));
        const float r1 = disc >= 0.0f ? q / (3.0f * c.x) : -1.0f, r2 = disc >= 0.0f ? c.z / q : -1.0f;
        u[1] = fmin(fmax(fmin(r1, r2), 0.0f), u[3]);
        u[2] = fmin(fmax(fmax(r1, r2), u[1]), u[3]);
        for (int j = 0; j < 4; ++j)
            g[j] = iso_cubic(c, u[j]);
    }
    const uint mask = (1u << ISO_COUNT) - 1u;
    /* Sides where the piece starts; a change against the carried sides is a crossing on the cell face. */
    uint sideStart = side0 & ~cubic;
    for (int i = 0; i < ISO_COUNT; ++i)
        if (cubic & (1u << i)) sideStart |= g[0] >= P->iso.value[i] ? 1u << i : 0u;
    if (!st->started) {
        st->inside = sideStart;
        st->started = 1;
    }
    const uint flipped = (sideStart ^ st->inside) & mask;
    for (int i = 0; i < ISO_COUNT; ++i)
        if (flipped & (1u << i)) {
            th[n] = ta;
            order[n] = i;
            ++n;
        }
    if (n) iso_composite(vol, knots, P, r, th, order, n, rgb, T, depth SHADOW_ARGS);
    uint side = sideStart;
    if (cubic) {
        const float tol = ISO_TOL_VOXELS / length(r->d); /* in ray parameter units */
        for (int j = 1; j < 4; ++j) {                    /* monotone pieces [u[j-1], u[j]] in ray order */
            n = 0;
            uint sideEnd = side;
            for (int i = 0; i < ISO_COUNT; ++i) {
                if (!(cubic & (1u << i))) continue;
                const float iso = P->iso.value[i];
                const uint bit = 1u << i;
                const uint s1 = g[j] >= iso ? bit : 0u;
                sideEnd = (sideEnd & ~bit) | s1;
                if (s1 != (side & bit)) {
                    th[n] = ta + iso_refine(c, iso, u[j - 1], u[j], (side & bit) != 0u, tol);
                    order[n] = i;
                    ++n;
                }
            }
            if (n) iso_composite(vol, knots, P, r, th, order, n, rgb, T, depth SHADOW_ARGS);
            side = sideEnd;
        }
    }
    st->inside = side;
}

/* Composites the iso-surfaces crossed between (t0, s0) and (t1, s1) in ray order. The sides where the
   segment starts and ends come from the march's own samples s0 and s1, so consecutive segments agree on
   them and a crossing on a segment end is counted once. */
inline void iso_segment(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                        const VolclGridRenderParams* P, const Ray* r, float t0, float s0, float t1, float s1,
                        float3* rgb, float* T, float* depth SHADOW_PARAMS) {
    if (!(*T > 0.0f)) return; /* behind an opaque surface nothing more shows */
    IsoState st;
    iso_begin(&st, r);
    st.started = 1;
    uint end = 0u;
    for (int i = 0; i < ISO_COUNT; ++i) {
        st.inside |= s0 >= P->iso.value[i] ? 1u << i : 0u;
        end |= s1 >= P->iso.value[i] ? 1u << i : 0u;
    }
#ifdef NAN_COLOR
    if (!isfinite(s0)) st.started = 0; /* the first finite cell sets the sides */
#endif
    iso_locate(vol, P, r, t0, &st);
    float ta = t0;
    const int maxSteps = (int)(P->grid.dims[0] + P->grid.dims[1] + P->grid.dims[2]) + 4; /* as in iso_march */
    for (int guard = 0; guard < maxSteps; ++guard) {
        const float tb = fmin(t1, st.tOut);
        if (tb > ta && iso_piece_needed(&st))
            iso_piece(vol, knots, P, r, &st, ta, tb, rgb, T, depth SHADOW_ARGS);
        ta = fmax(ta, tb);
        if (ta >= t1) break;
        iso_step(vol, P, &st);
    }
    /* A side the cubic leaves a hair off the sample at t1 is a crossing at t1. */
    uint flipped = (end ^ st.inside) & ((1u << ISO_COUNT) - 1u);
#ifdef NAN_COLOR
    if (!isfinite(s1) || !st.started) flipped = 0u; /* no crossing at a sample that is not finite */
#endif
    if (flipped) {
        float th[ISO_COUNT];
        int order[ISO_COUNT];
        int n = 0;
        for (int i = 0; i < ISO_COUNT; ++i)
            if (flipped & (1u << i)) {
                th[n] = t1;
                order[n] = i;
                ++n;
            }
        iso_composite(vol, knots, P, r, th, order, n, rgb, T, depth SHADOW_ARGS);
    }
}

/* Stateful form for a march that keeps an IsoState per ray (iso_begin before the loop): the DDA and the
   corners of the current cell carry over from one segment to the next, and so do the sides, so the march
   needs no samples of its own. Composites the crossings in [t0, t1] in ray order (t0 of each call is t1 of
   the last, or further on after empty space was skipped). */
inline void iso_march(__global const voxel_t* vol, __global const VolclTfKnot* knots,
                      const VolclGridRenderParams* P, const Ray* r, IsoState* st, float t0, float t1,
                      float3* rgb, float* T, float* depth SHADOW_PARAMS) {
    if (!(*T > 0.0f)) return; /* behind an opaque surface nothing more shows */
    float ta = t0;
    if (ta >= st->tOut) {
        /* A jump (first call or skipped space) relocates; otherwise the next cell is a step or two away. */
        if (!st->started || ta > st->tOut + fmin(st->tDelta.x, fmin(st->tDelta.y, st->tDelta.z)))
            iso_locate(vol, P, r, ta, st);
        else
            for (int s = 0; s < 6 && st->tOut <= ta; ++s)
                iso_step(vol, P, st);
    }
    /* A segment crosses at most dims[0] + dims[1] + dims[2] faces; the cap only matters when a voxel is
       below float resolution of t (cell steps would then not advance t). */
    const int maxSteps = (int)(P->grid.dims[0] + P->grid.dims[1] + P->grid.dims[2]) + 4;
    for (int guard = 0; guard < maxSteps; ++guard) {
        const float tb = fmin(t1, st->tOut);
        if (tb > ta && iso_piece_needed(st))
            iso_piece(vol, knots, P, r, st, ta, tb, rgb, T, depth SHADOW_ARGS);
        ta = fmax(ta, tb);
        if (ta >= t1) break;
        iso_step(vol, P, st);
    }
}
#endif
