// The dense decoder's AVX-512 passes (VBMI2 and friends): magnitude symbols, non-zero lists and signs of a
// row group, a lane per row; the same stream order as the scalar decoder. Each function carries its target,
// so the file builds with the baseline flags and runs only where avx512DenseDecoderKernels() found the CPU
// able.
#include "wavelet/entropy/DenseKernels.hpp"

#include <immintrin.h>

namespace volcl::entropy {

namespace {

// GCC 12 reports its own intrinsics' undefined-register idiom (_mm512_undefined_*) as (maybe) uninitialised.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#define VOLCL_SIMD_TARGET                                                                                    \
    __attribute__((target("avx512f,avx512bw,avx512cd,avx512dq,avx512vl,avx512vbmi2,bmi,bmi2,popcnt,lzcnt")))

// Lanes 0..nj-1 from v, the others `fill`; and back.
VOLCL_SIMD_TARGET inline __m512i loadLanes(const std::uint32_t* v, std::size_t nj, std::uint32_t fill) {
    const __mmask8 lanes = static_cast<__mmask8>((1u << nj) - 1u);
    return _mm512_cvtepu32_epi64(
        _mm256_mask_loadu_epi32(_mm256_set1_epi32(static_cast<int>(fill)), lanes, v));
}
VOLCL_SIMD_TARGET inline void storeStates(__m512i state, std::uint32_t* st, std::size_t nj) {
    _mm256_mask_storeu_epi32(st, static_cast<__mmask8>((1u << nj) - 1u), _mm512_cvtepi64_epi32(state));
}

// The new states of the `active` lanes after a decoding step gave s (64-bit lanes): the lanes below 2^16
// take the next 16-bit words of the stream in lane order, the scalar decoder's order.
VOLCL_SIMD_TARGET inline __m512i renormalise(__m512i state, __m512i s, __mmask8 active,
                                             const std::uint8_t* data, std::size_t size, std::size_t& pos) {
    const __mmask8 renorm = _mm512_mask_cmplt_epu64_mask(active, s, _mm512_set1_epi64(kRansLow));
    // vpexpandw puts the next words into the renormalising lanes in lane order (the mask spread to the low
    // word of each 64-bit lane); past the end the padding gives zeros.
    const __m512i w =
        _mm512_maskz_expandloadu_epi16(_pdep_u32(renorm, 0x11111111u), data + std::min(pos, size));
    pos += 2 * static_cast<std::size_t>(_mm_popcnt_u32(renorm));
    state = _mm512_mask_mov_epi64(state, active, s);
    return _mm512_mask_mov_epi64(state, renorm, _mm512_or_si512(_mm512_slli_epi64(s, 16), w));
}

// Decodes the magnitude symbols of columns [0, steps) of a row group, one column per step: lane i of the
// vectors is row i of the group, and the lanes that renormalise take the next words of the stream in lane
// order (an expanding load), which is the scalar decoder's order (x outer, row inner), so the stream is the
// same. `lastMask` is the set of rows active in the last column (rows of a group differ by one column at
// most when this runs with steps > min nx). Activities are gathered from the rows and symbols scattered to
// them (off the serial chain). States in 64-bit lanes: vpmuludq is half the latency of vpmulld.
VOLCL_SIMD_TARGET
void symbolsSimd(const RowJob* jobs, std::size_t nj, std::size_t steps, unsigned lastMaskBits, WordReader& in,
                 std::uint32_t* st, const PackedTables& pt) {
    const __mmask8 full = static_cast<__mmask8>((1u << nj) - 1u),
                   lastMask = static_cast<__mmask8>(lastMaskBits);
    // Rows addressed relative to the first row's arrays (byte offsets per lane).
    const auto* act0 = reinterpret_cast<const std::uint8_t*>(jobs[0].activity);
    std::uint8_t* const sym0 = jobs[0].syms;
    alignas(64) std::int64_t actOff[8] = {}, symOff[8] = {};
    for (std::size_t i = 0; i < nj; ++i) {
        actOff[i] = reinterpret_cast<const std::uint8_t*>(jobs[i].activity) - act0;
        symOff[i] = jobs[i].syms - sym0;
    }
    __m512i actIdx = _mm512_load_si512(actOff), symIdx = _mm512_load_si512(symOff);
    const __m512i four = _mm512_set1_epi64(4);
    __m512i state = loadLanes(st, nj, kRansLow);
    const __m512i offLo = _mm512_load_si512(pt.offset), offHi = _mm512_load_si512(pt.offset + 16);
    const __m512i one = _mm512_set1_epi64(1), two = _mm512_set1_epi64(2),
                  low32 = _mm512_set1_epi64(0xFFFFFFFF);
    const __m512i slotMask = _mm512_set1_epi64(kTableScale - 1),
                  maxClass = _mm512_set1_epi64(kActivityContexts - 1);
    const __m512i c125 = _mm512_set1_epi64(125), c62 = _mm512_set1_epi64(62);
    const __m512i m11 = _mm512_set1_epi64(0x7FF), m12 = _mm512_set1_epi64(0xFFF),
                  m6 = _mm512_set1_epi64(0x3F);
    const std::uint32_t* table = pt.entries.data();
    const std::uint8_t* data = in.data;
    const std::size_t size = in.size;
    std::size_t pos = in.pos;
    __m512i sym = _mm512_setzero_si512();
    for (std::size_t x = 0; x < steps; ++x) {
        const __mmask8 active = x + 1 == steps ? lastMask : full;
        // Activity class of activity + 4 base(previous symbol), as the scalar kActivityClass (u32 sum). The
        // encoder's westOf/activityClassesOf compute the same in 32-bit lanes (checked against the tables);
        // here the states' 64-bit lanes are kept, since conversions would lengthen the serial chain.
        const __m512i v = _mm512_min_epu64(sym, _mm512_or_si512(_mm512_and_si512(sym, one), two));
        const __m512i t = _mm512_max_epu64(_mm512_add_epi64(_mm512_srli_epi64(sym, 1), one), two);
        const __m512i act = _mm512_cvtepu32_epi64(
            _mm512_mask_i64gather_epi32(_mm256_setzero_si256(), active, actIdx, act0, 1));
        actIdx = _mm512_add_epi64(actIdx, four);
        const __m512i a = _mm512_and_si512(_mm512_add_epi64(act, _mm512_sllv_epi64(v, t)), low32);
        const __m512i lz = _mm512_lzcnt_epi64(a);
        // 2n - 1 + (top two bits) with n = 63 - lz, the bit length less one; a < 2 is the class a.
        __m512i cls = _mm512_add_epi64(_mm512_sub_epi64(c125, _mm512_add_epi64(lz, lz)),
                                       _mm512_srlv_epi64(a, _mm512_sub_epi64(c62, lz)));
        cls = _mm512_min_epi64(_mm512_max_epi64(cls, _mm512_min_epu64(a, one)), maxClass);
        const __m512i off = _mm512_maskz_permutex2var_epi32(0x5555, offLo, cls, offHi);
        // Eight scalar loads instead of vpgatherqq: the gather's latency is the longest link of the chain.
        alignas(64) std::uint64_t ix[8];
        _mm512_store_si512(ix, _mm512_add_epi64(off, _mm512_and_si512(state, slotMask)));
        const __m128i e01 =
            _mm_insert_epi64(_mm_cvtsi32_si128(static_cast<int>(table[ix[0]])), table[ix[1]], 1);
        const __m128i e23 =
            _mm_insert_epi64(_mm_cvtsi32_si128(static_cast<int>(table[ix[2]])), table[ix[3]], 1);
        const __m128i e45 =
            _mm_insert_epi64(_mm_cvtsi32_si128(static_cast<int>(table[ix[4]])), table[ix[5]], 1);
        const __m128i e67 =
            _mm_insert_epi64(_mm_cvtsi32_si128(static_cast<int>(table[ix[6]])), table[ix[7]], 1);
        const __m512i e = _mm512_inserti64x4(
            _mm512_castsi256_si512(_mm256_inserti128_si256(_mm256_castsi128_si256(e01), e23, 1)),
            _mm256_inserti128_si256(_mm256_castsi128_si256(e45), e67, 1), 1);
        sym = _mm512_and_si512(_mm512_srli_epi64(e, 23), m6);
        const __m512i freq = _mm512_and_si512(_mm512_srli_epi64(e, 11), m12);
        const __m512i s = _mm512_add_epi64(_mm512_mul_epu32(freq, _mm512_srli_epi64(state, kTableScaleBits)),
                                           _mm512_and_si512(e, m11));
        state = renormalise(state, s, active, data, size, pos);
        // 4 bytes per row: the 3 after x are written by the next steps or lie in the row's padding.
        _mm512_mask_i64scatter_epi32(sym0, active, symIdx, _mm512_cvtepi64_epi32(sym), 1);
        symIdx = _mm512_add_epi64(symIdx, one);
    }
    in.pos = pos;
    storeStates(state, st, nj);
}

// A row's list of non-zero coefficients (syms[x] != 0) as x | signBase[x] << 24 (j.nonZero, j.count), and
// the entries whose symbol has raw mantissa bits (symbol >= 4; j.withRawBits, j.rawCount), 16 columns per
// step, compressed in registers (vpcompressd to memory is microcoded). Also sets mag[x] to the symbol's
// base magnitude (the raw-bit pass then only visits the entries that have raw bits) and clears the row's
// sign classes. A scalar loop making the lists with plain x cost four stores per column.
VOLCL_SIMD_TARGET
void listNonZero(RowJob& j) {
    const __m512i iota = _mm512_set_epi32(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0);
    // kSymbolInfo.base of symbols 0-31 and 32-63 (two-register permutations).
    const std::uint32_t* baseTable = kSymbolInfo.base.data();
    const __m512i b0 = _mm512_load_si512(baseTable), b1 = _mm512_load_si512(baseTable + 16);
    const __m512i b2 = _mm512_load_si512(baseTable + 32), b3 = _mm512_load_si512(baseTable + 48);
    const std::size_t nx = j.nx;
    std::size_t count = 0, rawCount = 0;
    for (std::size_t x = 0; x < nx; x += 16) {
        const __mmask16 inRow =
            nx - x >= 16 ? __mmask16(0xFFFF) : static_cast<__mmask16>((1u << (nx - x)) - 1u);
        const __m128i sy = _mm_maskz_loadu_epi8(inRow, j.syms + x);
        const __mmask16 nz = _mm_mask_test_epi8_mask(inRow, sy, _mm_set1_epi8(-1));
        const __mmask16 raw = _mm_mask_cmpge_epu8_mask(inRow, sy, _mm_set1_epi8(4));
        const __m512i sym = _mm512_cvtepu8_epi32(sy);
        const __m512i base = _mm512_mask_blend_epi32(_mm512_test_epi32_mask(sym, _mm512_set1_epi32(32)),
                                                     _mm512_permutex2var_epi32(b0, sym, b1),
                                                     _mm512_permutex2var_epi32(b2, sym, b3));
        _mm512_mask_storeu_epi32(j.mag + x, inRow, base);
        _mm_mask_storeu_epi8(j.sgn + x, inRow, _mm_setzero_si128());
        const __m512i sb = _mm512_cvtepu16_epi32(_mm256_maskz_loadu_epi16(inRow, j.signBase + x));
        const __m512i entry = _mm512_or_si512(_mm512_add_epi32(iota, _mm512_set1_epi32(static_cast<int>(x))),
                                              _mm512_slli_epi32(sb, 24));
        _mm512_storeu_si512(j.nonZero + count, _mm512_maskz_compress_epi32(nz, entry));
        _mm512_storeu_si512(j.withRawBits + rawCount, _mm512_maskz_compress_epi32(raw, entry));
        count += static_cast<std::size_t>(_mm_popcnt_u32(nz));
        rawCount += static_cast<std::size_t>(_mm_popcnt_u32(raw));
    }
    j.count = count;
    j.rawCount = rawCount;
}

// Decodes the signs of a row group's non-zero coefficients, their n-th in step n (the scalar order): lane i
// is row i, whose n-th list entry (listNonZero) gives x and the neighbour part of the sign context; W's
// sign is the previous step's when that coefficient was at x - 1 (else W is zero). The sign classes are
// stored into the rows' sign bytes. The rows of a group are subbands of different orientation, so their
// sign models are disjoint and one gather and one scatter per step see no conflicts.
VOLCL_SIMD_TARGET
void signsSimd(const RowJob* jobs, std::size_t nj, std::size_t steps, const std::uint32_t* counts,
               WordReader& in, std::uint32_t* st, BitModel* models) {
    std::uint8_t* const sgn0 = jobs[0].sgn;
    const auto* list0 = reinterpret_cast<const std::uint8_t*>(jobs[0].nonZero);
    alignas(64) std::int64_t sgnOff[8] = {}, listOff[8] = {};
    for (std::size_t i = 0; i < nj; ++i) {
        sgnOff[i] = jobs[i].sgn - sgn0;
        listOff[i] = reinterpret_cast<const std::uint8_t*>(jobs[i].nonZero) - list0;
    }
    const __m512i rowOff = _mm512_load_si512(sgnOff);
    __m512i listIdx = _mm512_load_si512(listOff);
    __m512i state = loadLanes(st, nj, kRansLow);
    const __m512i count = loadLanes(counts, nj, 0);
    const __m512i scale = _mm512_set1_epi64(kBinaryScale), slotMask = _mm512_set1_epi64(kBinaryScale - 1);
    const __m512i one = _mm512_set1_epi64(1), four = _mm512_set1_epi64(4), xMask = _mm512_set1_epi64(kListX);
    const std::uint8_t* data = in.data;
    const std::size_t size = in.size;
    std::size_t pos = in.pos;
    __m512i sgn = _mm512_setzero_si512();
    __m512i prevX = _mm512_set1_epi64(-2);
    auto* p0s = reinterpret_cast<int*>(models);
    for (std::size_t n = 0; n < steps; ++n) {
        const __mmask8 active = _mm512_cmpgt_epu64_mask(count, _mm512_set1_epi64(static_cast<long long>(n)));
        const __m512i entry = _mm512_cvtepu32_epi64(
            _mm512_mask_i64gather_epi32(_mm256_setzero_si256(), active, listIdx, list0, 1));
        listIdx = _mm512_add_epi64(listIdx, four);
        const __m512i x = _mm512_and_si512(entry, xMask);
        const __mmask8 west = _mm512_cmpeq_epi64_mask(x, _mm512_add_epi64(prevX, one));
        prevX = x;
        const __m512i base = _mm512_srli_epi64(entry, 24);
        const __m512i ctx = _mm512_mask_add_epi64(base, west, base, sgn);
        const __m512i p0 =
            _mm512_cvtepu32_epi64(_mm512_mask_i64gather_epi32(_mm256_setzero_si256(), active, ctx, p0s, 4));
        const __m512i slot = _mm512_and_si512(state, slotMask);
        const __mmask8 neg = _mm512_cmpge_epu64_mask(slot, p0);
        const __m512i q = _mm512_sub_epi64(scale, p0);
        const __m512i freq = _mm512_mask_mov_epi64(p0, neg, q);
        const __m512i start = _mm512_maskz_mov_epi64(neg, p0);
        const __m512i s = _mm512_add_epi64(_mm512_mul_epu32(freq, _mm512_srli_epi64(state, kBinaryScaleBits)),
                                           _mm512_sub_epi64(slot, start));
        state = renormalise(state, s, active, data, size, pos);
        const __m512i up = _mm512_add_epi64(p0, _mm512_srli_epi64(q, 5));
        const __m512i down = _mm512_sub_epi64(p0, _mm512_srli_epi64(p0, 5));
        _mm512_mask_i64scatter_epi32(p0s, active, ctx,
                                     _mm512_cvtepi64_epi32(_mm512_mask_mov_epi64(up, neg, down)), 4);
        sgn = _mm512_mask_add_epi64(one, neg, one, one);
        // 4 bytes at x: the 3 after it are zero (coefficients after x, whose signs come in later steps, and
        // the slice buffer's zero border and padding).
        _mm512_mask_i64scatter_epi32(sgn0, active, _mm512_add_epi64(rowOff, x), _mm512_cvtepi64_epi32(sgn),
                                     1);
    }
    in.pos = pos;
    storeStates(state, st, nj);
}
#pragma GCC diagnostic pop

bool cpuHasDecoderSets() noexcept {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
           __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512vbmi2") &&
           __builtin_cpu_supports("bmi2") && __builtin_cpu_supports("popcnt");
}

constexpr DenseDecoderKernels kAvx512{symbolsSimd, listNonZero, signsSimd};

} // namespace

bool cpuHasDenseAvx512() noexcept {
    static const bool ok = cpuHasDecoderSets();
    return ok;
}

const DenseDecoderKernels* avx512DenseDecoderKernels() noexcept {
    return cpuHasDenseAvx512() ? &kAvx512 : nullptr;
}

} // namespace volcl::entropy
