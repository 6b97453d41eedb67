/* Motion estimation and compensation: block matching (integer and half-voxel) and overlapped block
   motion compensation with separable raised-cosine windows. The C++ references in wavelet/predict/
   follow the same rules; see MotionSearch.hpp and Compensation.hpp for them in words.

   Search specialisation: HALF_STEP (0: every candidate is a whole-voxel vector, one load per voxel;
   1: candidates may sit on half voxels, trilinear = mean of 2^k voxels), COST_SSD (0: SAD, 1: SSD).
   Costs are exact integers in units of (8 x sample) for SAD and (8 x sample)^2 for SSD. */

#ifndef HALF_STEP
#define HALF_STEP 0
#endif
#ifndef COST_SSD
#define COST_SSD 1
#endif

/* floor(h / 2) for any sign. */
inline int half_floor(int h) {
    return (h - (h & 1)) / 2;
}

/* Tie-break shared with the reference: lower cost, then smaller |v|_1, then smaller (z, y, x). */
inline bool motion_better(ulong ca, int4 va, ulong cb, int4 vb) {
    if (ca != cb) return ca < cb;
    const int la = abs(va.x) + abs(va.y) + abs(va.z), lb = abs(vb.x) + abs(vb.y) + abs(vb.z);
    if (la != lb) return la < lb;
    if (va.z != vb.z) return va.z < vb.z;
    if (va.y != vb.y) return va.y < vb.y;
    return va.x < vb.x;
}

/* 8 x the trilinear reference sample at voxel p displaced by v half voxels, clamp-to-edge. */
inline int sample8(__global const int* ref, int4 dims, int px, int py, int pz, int4 v) {
    const int hx = 2 * px + v.x, hy = 2 * py + v.y, hz = 2 * pz + v.z;
    const int x0 = half_floor(hx), y0 = half_floor(hy), z0 = half_floor(hz);
    const int x1 = x0 + (hx & 1), y1 = y0 + (hy & 1), z1 = z0 + (hz & 1);
    const int ax = clamp(x0, 0, dims.x - 1), bx = clamp(x1, 0, dims.x - 1);
    const int ay = clamp(y0, 0, dims.y - 1), by = clamp(y1, 0, dims.y - 1);
    const int az = clamp(z0, 0, dims.z - 1), bz = clamp(z1, 0, dims.z - 1);
    const int sx = dims.x, sxy = dims.x * dims.y;
    return ref[ax + sx * ay + sxy * az] + ref[bx + sx * ay + sxy * az] + ref[ax + sx * by + sxy * az] +
           ref[bx + sx * by + sxy * az] + ref[ax + sx * ay + sxy * bz] + ref[bx + sx * ay + sxy * bz] +
           ref[ax + sx * by + sxy * bz] + ref[bx + sx * by + sxy * bz];
}

/* Cost of one block (origin o, extent e inside the volume) for one candidate vector v. */
inline ulong block_cost(__global const int* cur, __global const int* ref, int4 dims, int4 o, int4 e, int4 v) {
    ulong cost = 0;
    const int sx = dims.x, sxy = dims.x * dims.y;
#if HALF_STEP
    for (int z = o.z; z < o.z + e.z; ++z)
        for (int y = o.y; y < o.y + e.y; ++y)
            for (int x = o.x; x < o.x + e.x; ++x) {
                const long d = 8 * (long)cur[x + sx * y + sxy * z] - (long)sample8(ref, dims, x, y, z, v);
#if COST_SSD
                cost += (ulong)(d * d);
#else
                cost += (ulong)(d < 0 ? -d : d);
#endif
            }
#else
    const int wx = v.x / 2, wy = v.y / 2, wz = v.z / 2;
    for (int z = o.z; z < o.z + e.z; ++z) {
        const int rz = clamp(z + wz, 0, dims.z - 1);
        for (int y = o.y; y < o.y + e.y; ++y) {
            const int ry = clamp(y + wy, 0, dims.y - 1);
            __global const int* c = cur + sx * y + sxy * z;
            __global const int* r = ref + sx * ry + sxy * rz;
            uint line = 0; /* one line of at most 32 voxels: |d| < 2^17, d^2 < 2^34 needs 64 bits */
            ulong line2 = 0;
            for (int x = o.x; x < o.x + e.x; ++x) {
                const int d = c[x] - r[clamp(x + wx, 0, dims.x - 1)];
#if COST_SSD
                line2 += (ulong)((long)d * (long)d);
#else
                line += (uint)abs(d);
#endif
            }
#if COST_SSD
            cost += line2;
#else
            cost += line;
#endif
        }
    }
#if COST_SSD
    cost *= 64;
#else
    cost *= 8;
#endif
#endif
    return cost;
}

/* Blocks sit every `pitch` voxels and span `extent` voxels (extent > pitch on coarse levels, where a block
   of the level's pitch would hold too few voxels to match reliably).
   One work-item per (block, dx, dy) pair of a stage; it scans dz. gid = pair + pairs * block with
   pairs = (2r+1)^2 and pair = dx + (2r+1) dy, so consecutive work-items read consecutive reference
   voxels. A candidate is centre + step * (dx, dy, dz) - r; candidates with a component beyond `limit`
   are skipped (the centre itself never is). Writes the pair's best cost and vector. */
__kernel void motion_search(__global const int* restrict cur, __global const int* restrict ref, int4 dims,
                            int pitch, int extent, int4 blocks, __global const int4* restrict centres,
                            int radius, int step, int limit, __global ulong* restrict pairCost,
                            __global int4* restrict pairVector) {
    const int side = 2 * radius + 1, pairs = side * side;
    const int gid = (int)get_global_id(0);
    const int nblocks = blocks.x * blocks.y * blocks.z;
    if (gid >= pairs * nblocks) return;
    const int block = gid / pairs, pair = gid - block * pairs;
    const int dx = pair % side - radius, dy = pair / side - radius;
    const int bx = block % blocks.x, by = (block / blocks.x) % blocks.y, bz = block / (blocks.x * blocks.y);
    const int4 o = (int4)(bx * pitch, by * pitch, bz * pitch, 0);
    const int4 e = (int4)(min(extent, dims.x - o.x), min(extent, dims.y - o.y), min(extent, dims.z - o.z), 0);
    const int4 c = centres[block];
    ulong best = ULONG_MAX;
    int4 bestV = c;
    const int vx = c.x + step * dx, vy = c.y + step * dy;
    if (abs(vx) <= limit && abs(vy) <= limit) {
        for (int dz = -radius; dz <= radius; ++dz) {
            const int vz = c.z + step * dz;
            if (abs(vz) > limit) continue;
            const int4 v = (int4)(vx, vy, vz, 0);
            const ulong cost = block_cost(cur, ref, dims, o, e, v);
            if (best == ULONG_MAX || motion_better(cost, v, best, bestV)) {
                best = cost;
                bestV = v;
            }
        }
    }
    pairCost[gid] = best;
    pairVector[gid] = bestV;
}

/* One work-item per block: the best of its pairs (ULONG_MAX marks a pair without a valid candidate). */
__kernel void motion_search_reduce(__global const ulong* restrict pairCost,
                                   __global const int4* restrict pairVector, int pairs, int nblocks,
                                   __global ulong* restrict bestCost, __global int4* restrict bestVector) {
    const int block = (int)get_global_id(0);
    if (block >= nblocks) return;
    ulong best = ULONG_MAX;
    int4 bestV = (int4)(0, 0, 0, 0);
    bool any = false;
    for (int p = 0; p < pairs; ++p) {
        const ulong c = pairCost[block * pairs + p];
        if (c == ULONG_MAX) continue;
        const int4 v = pairVector[block * pairs + p];
        if (!any || motion_better(c, v, best, bestV)) {
            best = c;
            bestV = v;
            any = true;
        }
    }
    bestCost[block] = best;
    bestVector[block] = bestV;
}

/* ------------------------------------------------------------------ compensation (float samples) */

/* Trilinear sample at voxel p displaced by v half voxels: the mean of the 8 clamped corners. */
inline __attribute__((always_inline)) float sample_half(__global const float* ref, int4 dims, int px, int py,
                                                        int pz, int4 v) {
    const int hx = 2 * px + v.x, hy = 2 * py + v.y, hz = 2 * pz + v.z;
    const int x0 = half_floor(hx), y0 = half_floor(hy), z0 = half_floor(hz);
    const int ax = clamp(x0, 0, dims.x - 1), bx = clamp(x0 + (hx & 1), 0, dims.x - 1);
    const int ay = clamp(y0, 0, dims.y - 1), by = clamp(y0 + (hy & 1), 0, dims.y - 1);
    const int az = clamp(z0, 0, dims.z - 1), bz = clamp(z0 + (hz & 1), 0, dims.z - 1);
    const int sx = dims.x, sxy = dims.x * dims.y;
    return (ref[ax + sx * ay + sxy * az] + ref[bx + sx * ay + sxy * az] + ref[ax + sx * by + sxy * az] +
            ref[bx + sx * by + sxy * az] + ref[ax + sx * ay + sxy * bz] + ref[bx + sx * ay + sxy * bz] +
            ref[ax + sx * by + sxy * bz] + ref[bx + sx * by + sxy * bz]) *
           0.125f;
}

/* Block modes (BlockMode in MotionField.hpp): 0 intra (block mean), 1 zero motion from reference 0,
   2 forward, 3 backward, 4 bidirectional (mean of forward and backward). */
inline __attribute__((always_inline)) float predict_voxel(int mode, __global const float* r0,
                                                          __global const float* r1, int4 dims, int x, int y,
                                                          int z, int4 f, int4 b, float intra) {
    switch (mode) {
    case 0:
        return intra;
    case 1:
        return r0[x + dims.x * (y + dims.y * z)];
    case 2:
        return sample_half(r0, dims, x, y, z, f);
    case 3:
        return sample_half(r1, dims, x, y, z, b);
    default:
        return 0.5f * (sample_half(r0, dims, x, y, z, f) + sample_half(r1, dims, x, y, z, b));
    }
}

/* One work-item per block: its mean and the residual energy of each mode in `modeMask` (bit m = mode m)
   over its own voxels; costs[5 block + m], modes outside the mask get 0 and are ignored by the host. */
__kernel void motion_mode_costs(__global const float* restrict cur, __global const float* restrict r0,
                                __global const float* restrict r1, int4 dims, int blockSize, int4 blocks,
                                __global const int4* restrict fwd, __global const int4* restrict bwd,
                                int modeMask, __global float* restrict costs,
                                __global float* restrict means) {
    const int block = (int)get_global_id(0);
    const int nblocks = blocks.x * blocks.y * blocks.z;
    if (block >= nblocks) return;
    const int bx = block % blocks.x, by = (block / blocks.x) % blocks.y, bz = block / (blocks.x * blocks.y);
    const int x0 = bx * blockSize, y0 = by * blockSize, z0 = bz * blockSize;
    const int x1 = min(dims.x, x0 + blockSize), y1 = min(dims.y, y0 + blockSize),
              z1 = min(dims.z, z0 + blockSize);
    const int sx = dims.x, sxy = dims.x * dims.y;
    float sum = 0;
    for (int z = z0; z < z1; ++z)
        for (int y = y0; y < y1; ++y) {
            float line = 0;
            for (int x = x0; x < x1; ++x)
                line += cur[x + sx * y + sxy * z];
            sum += line;
        }
    const float mean = sum / (float)((x1 - x0) * (y1 - y0) * (z1 - z0));
    means[block] = mean;
    const int4 f = fwd[block], b = bwd[block];
    for (int m = 0; m < 5; ++m) {
        float e = 0;
        if ((modeMask >> m) & 1) {
            for (int z = z0; z < z1; ++z)
                for (int y = y0; y < y1; ++y) {
                    float line = 0;
                    for (int x = x0; x < x1; ++x) {
                        const float d =
                            cur[x + sx * y + sxy * z] - predict_voxel(m, r0, r1, dims, x, y, z, f, b, mean);
                        line += d * d;
                    }
                    e += line;
                }
        }
        costs[5 * block + m] = e;
    }
}

/* The prediction of voxel (x, y, z): the weighted sum over the up to 8 blocks whose windows cover it. Per
   axis, the tables give the first covering block and the normalised weights of it and the next block (x
   entries, then y, then z). The row kernel below repeats these operations lane by lane in the same order,
   so both give the same bits (stored P/B frames depend on them). */
inline float compensate_voxel(__global const float* r0, __global const float* r1, int4 dims, int4 blocks,
                              __global const uchar* modes, __global const int4* fwd, __global const int4* bwd,
                              __global const float* intra, __global const int* first,
                              __global const float2* weights, int x, int y, int z) {
    const int fx = first[x], fy = first[dims.x + y], fz = first[dims.x + dims.y + z];
    const float2 wx = weights[x], wy = weights[dims.x + y], wz = weights[dims.x + dims.y + z];
    float p = 0;
    for (int c = 0; c < 8; ++c) {
        const float w = ((c & 1) ? wx.y : wx.x) * ((c & 2) ? wy.y : wy.x) * ((c & 4) ? wz.y : wz.x);
        if (w == 0.0f) continue;
        const int b = (fx + (c & 1)) + blocks.x * ((fy + ((c >> 1) & 1)) + blocks.y * (fz + (c >> 2)));
        p += w * predict_voxel(modes[b], r0, r1, dims, x, y, z, fwd[b], bwd[b], intra[b]);
    }
    return p;
}

/* Overlapped block motion compensation, one work-item per voxel (x = get_global_id(0)): block sizes below 8,
   where 8 voxels along x span more than a block and its two neighbours. */
__kernel void motion_compensate(__global const float* restrict r0, __global const float* restrict r1,
                                int4 dims, int4 blocks, __global const uchar* restrict modes,
                                __global const int4* restrict fwd, __global const int4* restrict bwd,
                                __global const float* restrict intra, __global const int* restrict first,
                                __global const float2* restrict weights, __global float* restrict out) {
    const int x = (int)get_global_id(0), y = (int)get_global_id(1), z = (int)get_global_id(2);
    if (x >= dims.x || y >= dims.y || z >= dims.z) return;
    out[x + dims.x * (y + dims.y * z)] =
        compensate_voxel(r0, r1, dims, blocks, modes, fwd, bwd, intra, first, weights, x, y, z);
}

/* ------------------------------------------------------------------ compensation of rows (typed samples)

   The row kernels read the reference frames in their voxel type, REF_TYPE: 0 uchar, 1 ushort, 2 short,
   3 float. Every value converts to float exactly, as the host's conversion would, so a decoder keeps its
   reference frames as they are, with no float copy. */

#ifndef REF_TYPE
#define REF_TYPE 3
#endif
#if REF_TYPE == 0
typedef uchar ref_t;
#elif REF_TYPE == 1
typedef ushort ref_t;
#elif REF_TYPE == 2
typedef short ref_t;
#else
typedef float ref_t;
#endif

/* The reconstruction's output voxels, OUT_TYPE (same numbering), default the references' type. A reference
   moved by a global sub-voxel translation is float while the frame keeps its integer type. */
#ifndef OUT_TYPE
#define OUT_TYPE REF_TYPE
#endif
#if OUT_TYPE == 0
typedef uchar out_t;
#define OUT_CONVERT8 convert_uchar8
#define OUT_LO 0.0f
#define OUT_HI 255.0f
#elif OUT_TYPE == 1
typedef ushort out_t;
#define OUT_CONVERT8 convert_ushort8
#define OUT_LO 0.0f
#define OUT_HI 65535.0f
#elif OUT_TYPE == 2
typedef short out_t;
#define OUT_CONVERT8 convert_short8
#define OUT_LO -32768.0f
#define OUT_HI 32767.0f
#else
typedef float out_t;
#endif
/* ROUND_PREDICTION 0: the prediction stays float before the residual is added (the codec's float
   prediction of lossy integer frames); 1: it is rounded to the output type first. */
#ifndef ROUND_PREDICTION
#define ROUND_PREDICTION 1
#endif

/* toVoxel (wavelet/BrickVoxels.hpp) for 8 values of the output type: integer types clamp, then round to
   nearest even; NaN, which the host's clamp passes on and its integer conversion turns into 0, gives 0.
   Floats unchanged. */
inline float8 to_voxel8(float8 v) {
#if OUT_TYPE == 3
    return v;
#else
    return select(rint(clamp(v, OUT_LO, OUT_HI)), (float8)(0.0f), isnan(v));
#endif
}

/* Eight reference samples along x from `row` starting at index `x`, clamped to [0, n): one vector load
   inside the row, lane by lane at its ends. */
inline __attribute__((always_inline)) float8 row8(__global const ref_t* row, int x, int n) {
    if (x >= 0 && x + 8 <= n) return convert_float8(vload8(0, row + x));
    const int m = n - 1; /* no private array: PoCL would keep one per work-item of the group */
    return (float8)((float)row[clamp(x, 0, m)], (float)row[clamp(x + 1, 0, m)],
                    (float)row[clamp(x + 2, 0, m)], (float)row[clamp(x + 3, 0, m)],
                    (float)row[clamp(x + 4, 0, m)], (float)row[clamp(x + 5, 0, m)],
                    (float)row[clamp(x + 6, 0, m)], (float)row[clamp(x + 7, 0, m)]);
}

/* sample_half for the 8 voxels (x0 .. x0 + 7, y, z) with one vector v: the x corners of lane i are
   x0 + i + floor(v.x / 2) and that + (v.x & 1), so each corner row is one vector load. Same sum order.
   A whole-voxel component makes both corners along it the same voxel (the clamped indices are equal), so
   the 8 loads need no test of the vector's parity; away from the x ends of the row they need no clamps. */
inline __attribute__((always_inline)) float8 sample_half8(__global const ref_t* ref, int4 dims, int x0, int y,
                                                          int z, int4 v) {
    const int hy = 2 * y + v.y, hz = 2 * z + v.z;
    const int y0 = half_floor(hy), z0 = half_floor(hz);
    const int ay = clamp(y0, 0, dims.y - 1), by = clamp(y0 + (hy & 1), 0, dims.y - 1);
    const int az = clamp(z0, 0, dims.z - 1), bz = clamp(z0 + (hz & 1), 0, dims.z - 1);
    const int xa = x0 + half_floor(v.x), xb = xa + (v.x & 1);
    const int sx = dims.x, sxy = dims.x * dims.y;
    __global const ref_t* r00 = ref + sx * ay + sxy * az;
    __global const ref_t* r10 = ref + sx * by + sxy * az;
    __global const ref_t* r01 = ref + sx * ay + sxy * bz;
    __global const ref_t* r11 = ref + sx * by + sxy * bz;
    float8 a00, b00, a10, b10, a01, b01, a11, b11;
    if (xa >= 0 && xb + 8 <= sx) {
        a00 = convert_float8(vload8(0, r00 + xa));
        b00 = convert_float8(vload8(0, r00 + xb));
        a10 = convert_float8(vload8(0, r10 + xa));
        b10 = convert_float8(vload8(0, r10 + xb));
        a01 = convert_float8(vload8(0, r01 + xa));
        b01 = convert_float8(vload8(0, r01 + xb));
        a11 = convert_float8(vload8(0, r11 + xa));
        b11 = convert_float8(vload8(0, r11 + xb));
    } else {
        a00 = row8(r00, xa, sx);
        b00 = row8(r00, xb, sx);
        a10 = row8(r10, xa, sx);
        b10 = row8(r10, xb, sx);
        a01 = row8(r01, xa, sx);
        b01 = row8(r01, xb, sx);
        a11 = row8(r11, xa, sx);
        b11 = row8(r11, xb, sx);
    }
    return (a00 + b00 + a10 + b10 + a01 + b01 + a11 + b11) * 0.125f;
}

/* predict_voxel for the 8 voxels (x0 .. x0 + 7, y, z), one block's mode and vectors; lanes outside the
   volume read clamped samples. */
inline __attribute__((always_inline)) float8 predict8(int mode, __global const ref_t* r0,
                                                      __global const ref_t* r1, int4 dims, int x0, int y,
                                                      int z, int4 f, int4 b, float intra) {
    switch (mode) {
    case 0:
        return (float8)(intra);
    case 1:
        return row8(r0 + dims.x * (y + dims.y * z), x0, dims.x);
    case 2:
        return sample_half8(r0, dims, x0, y, z, f);
    case 3:
        return sample_half8(r1, dims, x0, y, z, b);
    default:
        return 0.5f * (sample_half8(r0, dims, x0, y, z, f) + sample_half8(r1, dims, x0, y, z, b));
    }
}

/* The OBMC prediction of the 8 voxels (xs .. xs + 7, y, z), for blocks of 8 voxels or more. xs is
   `overlap` mod 8 below a multiple of 8, so along x every voxel of the group inside the volume has the same
   first covering block `lo` (the table's first[] is clamp(floor((x - overlap) / B), 0, nb - 1)), and the
   second one is lo + 1: two block predictions per y/z block pair, blended lane by lane with the x weights.
   The terms are added in compensate_voxel's order, and a zero weight adds exactly nothing (a second block
   with zero weight on every lane is not predicted at all), so the prediction has compensate_voxel's bits.
   Lanes outside the volume carry clamped tables and samples; the caller does not store them. */
inline __attribute__((always_inline)) float8 obmc8(__global const ref_t* r0, __global const ref_t* r1,
                                                   int4 dims, int4 blocks, __global const uchar* modes,
                                                   __global const int4* fwd, __global const int4* bwd,
                                                   __global const float* intra, __global const int* first,
                                                   __global const float2* weights, int xs, int y, int z) {
    float8 wx0, wx1;
    if (xs >= 0 && xs + 8 <= dims.x) {
        const float16 wxx = vload16(0, (__global const float*)(weights + xs));
        wx0 = wxx.even;
        wx1 = wxx.odd;
    } else {
        const int m = dims.x - 1;
        const float2 w0 = weights[clamp(xs, 0, m)], w1 = weights[clamp(xs + 1, 0, m)],
                     w2 = weights[clamp(xs + 2, 0, m)], w3 = weights[clamp(xs + 3, 0, m)],
                     w4 = weights[clamp(xs + 4, 0, m)], w5 = weights[clamp(xs + 5, 0, m)],
                     w6 = weights[clamp(xs + 6, 0, m)], w7 = weights[clamp(xs + 7, 0, m)];
        wx0 = (float8)(w0.x, w1.x, w2.x, w3.x, w4.x, w5.x, w6.x, w7.x);
        wx1 = (float8)(w0.y, w1.y, w2.y, w3.y, w4.y, w5.y, w6.y, w7.y);
    }
    const int lo = first[max(xs, 0)];
    const bool second = any(wx1 != (float8)(0.0f));
    const int fy = first[dims.x + y], fz = first[dims.x + dims.y + z];
    const float2 wy = weights[dims.x + y], wz = weights[dims.x + dims.y + z];
    float8 p = (float8)(0.0f);
    for (int c = 0; c < 4; ++c) { /* (y, z) corner in compensate_voxel's order; x inside */
        const float wyc = (c & 1) ? wy.y : wy.x, wzc = (c & 2) ? wz.y : wz.x;
        if (wyc == 0.0f || wzc == 0.0f) continue;
        const int b0 = blocks.x * ((fy + (c & 1)) + blocks.y * (fz + (c >> 1))) + lo;
        const float8 w0 = wx0 * wyc * wzc, w1 = wx1 * wyc * wzc;
        const float8 p0 = predict8(modes[b0], r0, r1, dims, xs, y, z, fwd[b0], bwd[b0], intra[b0]);
        p += w0 * p0;
        if (second) {
            const int b1 = b0 + 1;
            const float8 p1 = predict8(modes[b1], r0, r1, dims, xs, y, z, fwd[b1], bwd[b1], intra[b1]);
            p += w1 * p1;
        }
    }
    return p;
}

/* Overlapped block motion compensation for blocks of 8 voxels or more: one work-item per 8 voxels along x
   starting at xs = start + 8 get_global_id(0), start = (overlap mod 8) - 8 or 0 (see obmc8); writes the
   float prediction. */
__kernel void motion_compensate_rows(__global const ref_t* restrict r0, __global const ref_t* restrict r1,
                                     int4 dims, int4 blocks, int start, __global const uchar* restrict modes,
                                     __global const int4* restrict fwd, __global const int4* restrict bwd,
                                     __global const float* restrict intra, __global const int* restrict first,
                                     __global const float2* restrict weights, __global float* restrict out) {
    const int xs = start + 8 * (int)get_global_id(0), y = (int)get_global_id(1), z = (int)get_global_id(2);
    if (xs >= dims.x || y >= dims.y || z >= dims.z) return;
    const float8 p = obmc8(r0, r1, dims, blocks, modes, fwd, bwd, intra, first, weights, xs, y, z);
    __global float* o = out + dims.x * (y + dims.y * z);
    if (xs >= 0 && xs + 8 <= dims.x) {
        vstore8(p, 0, o + xs);
    } else {
        for (int i = max(0, -xs); i < 8 && xs + i < dims.x; ++i)
            o[xs + i] = p[i];
    }
}

/* The decoder's reconstruction of a P/B frame in one pass, same work-items as motion_compensate_rows: the
   prediction converted to the output type (the codec's rounded prediction, quantisedPrediction; kept float
   with ROUND_PREDICTION 0), plus the decoded residual, converted again (predictedVoxel in
   wavelet/predict/Residual.hpp), written as voxels of OUT_TYPE. */
__kernel void motion_reconstruct_rows(__global const ref_t* restrict r0, __global const ref_t* restrict r1,
                                      int4 dims, int4 blocks, int start, __global const uchar* restrict modes,
                                      __global const int4* restrict fwd, __global const int4* restrict bwd,
                                      __global const float* restrict intra,
                                      __global const int* restrict first,
                                      __global const float2* restrict weights,
                                      __global const float* restrict residual, __global out_t* restrict out) {
    const int xs = start + 8 * (int)get_global_id(0), y = (int)get_global_id(1), z = (int)get_global_id(2);
    if (xs >= dims.x || y >= dims.y || z >= dims.z) return;
    const float8 prediction = obmc8(r0, r1, dims, blocks, modes, fwd, bwd, intra, first, weights, xs, y, z);
#if ROUND_PREDICTION
    const float8 p = to_voxel8(prediction);
#else
    const float8 p = prediction;
#endif
    const int row = dims.x * (y + dims.y * z);
    __global const float* r = residual + row;
    __global out_t* o = out + row;
    if (xs >= 0 && xs + 8 <= dims.x) {
        const float8 v = to_voxel8(p + vload8(0, r + xs));
#if OUT_TYPE == 3
        vstore8(v, 0, o + xs);
#else
        vstore8(OUT_CONVERT8(v), 0, o + xs);
#endif
    } else {
        for (int i = max(0, -xs); i < 8 && xs + i < dims.x; ++i) {
            const float v = to_voxel8((float8)(p[i] + r[xs + i])).s0;
            o[xs + i] = (out_t)v;
        }
    }
}
