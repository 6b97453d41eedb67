/* Samples a packed transfer function at many data values (tests host/kernel bit-identity of tf_sample). */
#include "common/tf_lookup.h"

/* out[i] = tf_sample(s[i]) as (r, g, b, tau). */
__kernel void tf_sample_points(__global const VolclTfKnot* knots, uint knotCount, __global const float* s,
                               __global float4* out, uint n) {
    const size_t i = get_global_id(0);
    if (i >= n) return;
    out[i] = tf_sample(knots, knotCount, s[i]);
}
