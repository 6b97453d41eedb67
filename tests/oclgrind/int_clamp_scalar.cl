/* Oclgrind 21.10 bug reproducer: integer clamp/min/max of a vector with scalar bounds are wrong past lane 0. */
/* in = 0..7: clamp(v, 2, 4) must give 2 2 2 3 4 4 4 4 in every lane; the vector-bound form is the workaround
   volcl's kernels use (their scalar-bound calls read out of bounds on Oclgrind). */
__kernel void int_clamp_scalar(__global const int* in, __global int* scalarBounds,
                               __global int* vectorBounds) {
    const int8 v = vload8(0, in);
    const int lo = in[0] + 2, hi = in[0] + 4;
    vstore8(clamp(v, lo, hi), 0, scalarBounds);
    vstore8(clamp(v, (int8)(lo), (int8)(hi)), 0, vectorBounds);
}
