/* Oclgrind 21.10 false positive: fmax of two halves of a float16 reads as uninitialised (--uninitialized). */
/* `in` holds 16 initialised floats, so every value here is defined; Oclgrind still reports "Controlflow depends
   on uninitialized value" at the fmax of v.lo and v.hi (any 8- or 4-lane part of a float16 passed to a
   builtin does it, while v.lo + v.hi does not). The scalar tree below is what preint_hmax does instead. */
__kernel void fmax_half_vectors(__global const float* in, __global float* halves, __global float* scalars) {
    const float16 v = vload16(0, in);
    const float8 a = fmax(v.lo, v.hi);
    halves[0] = fmax(fmax(fmax(a.s0, a.s1), fmax(a.s2, a.s3)), fmax(fmax(a.s4, a.s5), fmax(a.s6, a.s7)));
    scalars[0] =
        fmax(fmax(fmax(fmax(v.s0, v.s1), fmax(v.s2, v.s3)), fmax(fmax(v.s4, v.s5), fmax(v.s6, v.s7))),
             fmax(fmax(fmax(v.s8, v.s9), fmax(v.sa, v.sb)), fmax(fmax(v.sc, v.sd), fmax(v.se, v.sf))));
}
