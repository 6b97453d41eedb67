/* Plain copy kernels: the memory-bandwidth ceiling that every streaming kernel is reported against. */

/* One float16 per work-item: the fastest streaming form on PoCL (see notes/pocl-performance.md).
   n16 = number of float16 elements; the host copies any tail itself. */
__kernel void copy_float16(__global const float16* restrict src, __global float16* restrict dst, uint n16) {
    size_t i = get_global_id(0);
    if (i < n16) dst[i] = src[i];
}

/* Scalar copy, any length. */
__kernel void copy_float(__global const float* restrict src, __global float* restrict dst, uint n) {
    size_t i = get_global_id(0);
    if (i < n) dst[i] = src[i];
}
