/* Transfer-function sampling in kernels; bit-identical to TransferFunction::sampleFloat on the host. */
#ifndef VOLCL_TRANSFER_FUNCTION_H
#define VOLCL_TRANSFER_FUNCTION_H

#include "volcl_shared.h"

#pragma OPENCL FP_CONTRACT OFF

/* Index of the interval holding s: the last knot k with knots[k].s < s (0 when s <= knots[0].s). */
inline uint tf_find_interval(__global const VolclTfKnot* knots, uint count, float s) {
    uint lo = 0, hi = count; /* invariant: answer in [lo, hi) */
    while (hi - lo > 1) {
        uint mid = (lo + hi) / 2;
        if (knots[mid].s < s) lo = mid; else hi = mid;
    }
    return lo;
}

/* (r, g, b, tau) at data value s. */
inline float4 tf_sample(__global const VolclTfKnot* knots, uint count, float s) {
    uint k = tf_find_interval(knots, count, s);
    __global const VolclTfKnot* kn = knots + k;
    /* Clamped so that s = +inf past the last knot (slope 0) gives its value, not inf * 0 = NaN. */
    float d = s > kn->s ? fmin(s - kn->s, FLT_MAX) : 0.0f;
    float4 v = (float4)(kn->value[0], kn->value[1], kn->value[2], kn->value[3]);
    float4 g = (float4)(kn->slope[0], kn->slope[1], kn->slope[2], kn->slope[3]);
    return v + d * g;
}

#endif
