/* Iso-surface root finding and in-order compositing for the ray marcher (included by raymarch.cl). */
#if ISO_COUNT > 0
/* Root of s(t) = iso in [ta, tb] (fa = s(ta) - iso, opposite in sign to s(tb) - iso): bisection on the
   trilinear field until the interval no longer shrinks in float or 40 halvings (2^-40 of the step). */
inline float refine_iso(__global const voxel_t* vol, const VolclRenderParams* P, const Ray* r, float iso, float ta,
                        float fa, float tb) {
    for (int it = 0; it < 40; ++it) {
        const float tm = 0.5f * (ta + tb);
        if (tm <= ta || tm >= tb) break;
        const float fm = sample_volume(vol, P, ray_at(r, tm)) - iso;
        if ((fm < 0.0f) == (fa < 0.0f)) {
            ta = tm;
            fa = fm;
        } else {
            tb = tm;
        }
    }
    return 0.5f * (ta + tb);
}

/* Composites the iso-surfaces crossed between (t0, s0) and (t1, s1) in ray order. */
inline void iso_segment(__global const voxel_t* vol, __global const VolclTfKnot* knots, const VolclRenderParams* P,
                        const Ray* r, float t0, float s0, float t1, float s1, float3* rgb, float* T, float* depth) {
    float th[ISO_COUNT];
    int order[ISO_COUNT];
    int n = 0;
    for (int i = 0; i < ISO_COUNT; ++i) {
        const float iso = P->isoValue[i][0];
        const float f0 = s0 - iso, f1 = s1 - iso;
        if ((f0 < 0.0f) != (f1 < 0.0f)) {
            th[n] = refine_iso(vol, P, r, iso, t0, f0, t1);
            order[n] = i;
            ++n;
        }
    }
    for (int a = 1; a < n; ++a) /* insertion sort by hit distance */
        for (int b = a; b > 0 && th[b] < th[b - 1]; --b) {
            const float tt = th[b]; th[b] = th[b - 1]; th[b - 1] = tt;
            const int oo = order[b]; order[b] = order[b - 1]; order[b - 1] = oo;
        }
    for (int a = 0; a < n; ++a) {
        const int i = order[a];
        const float alpha = P->isoColor[i][3];
        float3 c = v3(P->isoColor[i]);
        const float3 p = ray_at(r, th[a]);
#ifdef NEEDS_LIGHTS
        c = light_sample(vol, knots, P, r, r->oWorld + th[a] * r->dWorld, p, c);
#endif
        if (isinf(*depth)) *depth = th[a];
        *rgb += *T * alpha * c;
        *T *= 1.0f - alpha;
    }
}
#endif
