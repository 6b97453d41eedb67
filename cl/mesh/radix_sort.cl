/* Stable LSD radix sort of 32-bit keys with 32-bit values on the device: 4 passes of 8-bit digits, each a
   block histogram, one exclusive scan over (digit, block) and a block-ordered scatter. Also the counting sort
   that bins sorted faces into screen tiles keeps its order the same way (mesh_kbuffer.cl). Each block is a
   contiguous run of keys handled by one work-item in order, so the scatter is stable without atomics.
   RADIX_BLOCKS: number of blocks (work-items of the histogram and scatter launches). */
#ifndef RADIX_BLOCKS
#define RADIX_BLOCKS 128
#endif

/* Keys of block b: [b * per, min(n, (b + 1) * per)). */
inline uint radix_per(uint n) {
    return (n + RADIX_BLOCKS - 1) / RADIX_BLOCKS;
}

/* hist[d * RADIX_BLOCKS + b] = number of keys of block b whose digit at `shift` is d. */
__kernel void radix_histogram(__global const uint* keys, const uint n, const uint shift,
                              __global uint* hist) {
    const uint b = get_global_id(0);
    if (b >= RADIX_BLOCKS) return;
    uint count[256];
    for (uint d = 0; d < 256; ++d)
        count[d] = 0;
    const uint per = radix_per(n);
    const uint lo = min(n, b * per), hi = min(n, lo + per);
    for (uint i = lo; i < hi; ++i)
        count[(keys[i] >> shift) & 255u]++;
    for (uint d = 0; d < 256; ++d)
        hist[d * RADIX_BLOCKS + b] = count[d];
}

/* In-place exclusive prefix sum of `count` entries (one work-item; a few ten thousand entries). */
__kernel void exclusive_scan(__global uint* data, const uint count, __global uint* total) {
    if (get_global_id(0) != 0) return;
    uint sum = 0;
    for (uint i = 0; i < count; ++i) {
        const uint v = data[i];
        data[i] = sum;
        sum += v;
    }
    total[0] = sum;
}

/* Writes every key of block b (and its value) to its place: the scanned offset of (digit, block) plus the
   number of earlier keys of the block with that digit. */
__kernel void radix_scatter(__global const uint* keysIn, __global const uint* valsIn, __global uint* keysOut,
                            __global uint* valsOut, const uint n, const uint shift,
                            __global const uint* offsets) {
    const uint b = get_global_id(0);
    if (b >= RADIX_BLOCKS) return;
    uint next[256];
    for (uint d = 0; d < 256; ++d)
        next[d] = offsets[d * RADIX_BLOCKS + b];
    const uint per = radix_per(n);
    const uint lo = min(n, b * per), hi = min(n, lo + per);
    for (uint i = lo; i < hi; ++i) {
        const uint k = keysIn[i];
        const uint pos = next[(k >> shift) & 255u]++;
        keysOut[pos] = k;
        valsOut[pos] = valsIn[i];
    }
}
