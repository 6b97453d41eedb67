/* Counter-based random numbers shared by the OpenCL path tracer and its C++ reference (same stream on both):
   a stream is keyed by (seed, pixel, sample) and its n-th number is a hash of the key and n, so any sample
   of any pixel is reproducible on its own, in any launch order. Hash: Wellons' lowbias32. */
#ifndef VOLCL_COUNTER_RNG_H
#define VOLCL_COUNTER_RNG_H

#ifdef __OPENCL_VERSION__
typedef uint volcl_rng_u32;
#define VOLCL_RNG_FN inline
#else
#include <cstdint>
typedef std::uint32_t volcl_rng_u32;
#define VOLCL_RNG_FN inline
#endif

VOLCL_RNG_FN volcl_rng_u32 volcl_hash32(volcl_rng_u32 x) {
    x ^= x >> 16;
    x *= 0x7feb352dU;
    x ^= x >> 15;
    x *= 0x846ca68bU;
    x ^= x >> 16;
    return x;
}

typedef struct VolclRng {
    volcl_rng_u32 key, counter;
} VolclRng;

VOLCL_RNG_FN VolclRng volcl_rng_start(volcl_rng_u32 seed, volcl_rng_u32 pixel, volcl_rng_u32 sample) {
    VolclRng r;
    r.key = volcl_hash32(seed * 0x9e3779b9U ^ volcl_hash32(pixel ^ volcl_hash32(sample + 0x632be5abU)));
    r.counter = 0U;
    return r;
}

/* The next number of the stream as a 24-bit integer; divided by 2^24 it is uniform in [0, 1). */
VOLCL_RNG_FN volcl_rng_u32 volcl_rng_next24(VolclRng* r) {
    const volcl_rng_u32 n = r->counter;
    r->counter = n + 1U;
    return volcl_hash32(r->key ^ volcl_hash32(n * 0x85ebca6bU + 0xc2b2ae35U)) >> 8;
}

#endif
