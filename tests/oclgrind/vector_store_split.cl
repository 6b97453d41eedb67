/* Oclgrind 21.10 false positive: a float4 built from scalars and stored reads as an uninitialised write. */
/* Every value is defined. On an optimised build Oclgrind splits `out[l] = (float4)(...)` into a store of the
   whole vector as undef followed by one store per element, and --uninitialized reports the first ("Uninitialized
   value written to global memory"); the stored result is right. vstore4 of the same vector is not split. With
   -cl-opt-disable (how run_kernels.sh checks for uninitialised values) the split does not happen. */
__kernel void vector_store_split(__global const float* in, __global float4* assigned,
                                 __global float* stored) {
    float r[4];
    vstore4(vload4(0, in), 0, r);
    for (int l = 0; l < 4; ++l) {
        assigned[l] = (float4)(r[l], r[l] + 1.0f, r[l] + 2.0f, r[l] + 3.0f);
        vstore4((float4)(r[l], r[l] + 1.0f, r[l] + 2.0f, r[l] + 3.0f), l, stored);
    }
}
