// The dense encoder's AVX-512 passes (the decoder's sets plus IFMA): row pass, sign events and the grouped
// backward rANS pass, writing the same bytes as the scalar encoder. Each function carries its target, so the
// file builds with the baseline flags and runs only where avx512DenseEncoderKernels() found the CPU able.
#include "wavelet/entropy/DenseKernels.hpp"

#include <immintrin.h>

namespace volcl::entropy {

bool cpuHasDenseAvx512() noexcept; // DenseDecoderAvx512.cpp

namespace {

// GCC 12 reports its own intrinsics' undefined-register idiom (_mm512_undefined_*) as (maybe) uninitialised.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
#define VOLCL_SIMD_ENCODER_TARGET                                                                            \
    __attribute__((target("avx512f,avx512bw,avx512cd,avx512dq,avx512vl,avx512vbmi2,avx512ifma,bmi,bmi2,"     \
                          "popcnt,lzcnt")))

// ceil(2^52 / f) for f in [2, 4096]: floor(s m / 2^52) = floor(s / f) for s < 2^32, since s m / 2^52
// exceeds s / f by less than s / 2^52 < 2^-20 and s / f is at least 1/f >= 2^-12 short of the next
// integer. One 52-bit multiply-high (vpmadd52huq). For f = 1, 2^52 - 1 gives s - 1 (s >= 1), which the
// SIMD pass makes up for in the start.
constexpr std::array<std::uint64_t, 4097> kReciprocal52 = [] {
    std::array<std::uint64_t, 4097> r{};
    r[1] = (std::uint64_t(1) << 52) - 1;
    for (std::uint64_t f = 2; f <= 4096; ++f)
        r[f] = ((std::uint64_t(1) << 52) + f - 1) / f;
    return r;
}();

// Starts of the groups of events[0, n) (maximal runs of strictly increasing lane) into `starts`, n after
// the last one; returns the group count. Resolves the pending symbols in place on the way (their slots
// from `codeSlots`, the lane kept). 16 events per step: a boundary is a lane <= the previous event's lane.
VOLCL_SIMD_ENCODER_TARGET
std::size_t resolveAndGroup(RansEvent* ev, std::size_t n, const RansEvent* codeSlots, std::uint32_t* starts) {
    __m512i prev = _mm512_set1_epi32(7); // before the first event: no lane is above it
    const __m512i iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const __m512i freqBits = _mm512_set1_epi32(static_cast<int>(kEventFreqMask << kEventFreqShift)),
                  fieldMask = _mm512_set1_epi32(kEventFieldMask),
                  laneBits = _mm512_set1_epi32(static_cast<int>(~0u << kEventLaneShift));
    std::size_t g = 0;
    for (std::size_t i = 0; i < n; i += 16) {
        const auto valid = static_cast<__mmask16>(n - i >= 16 ? 0xFFFFu : (1u << (n - i)) - 1u);
        const __m512i e = _mm512_maskz_loadu_epi32(valid, ev + i);
        const __mmask16 pending = _mm512_mask_testn_epi32_mask(valid, e, freqBits);
        const __m512i slots = _mm512_mask_i32gather_epi32(e, pending, _mm512_and_si512(e, fieldMask),
                                                          reinterpret_cast<const int*>(codeSlots), 4);
        _mm512_mask_storeu_epi32(ev + i, pending, _mm512_or_si512(slots, _mm512_and_si512(e, laneBits)));
        const __m512i lane = _mm512_srli_epi32(e, kEventLaneShift);
        const __mmask16 bound =
            _mm512_mask_cmple_epu32_mask(valid, lane, _mm512_alignr_epi32(lane, prev, 15));
        _mm512_mask_compressstoreu_epi32(starts + g, bound,
                                         _mm512_add_epi32(iota, _mm512_set1_epi32(static_cast<int>(i))));
        g += static_cast<std::size_t>(_mm_popcnt_u32(bound));
        prev = lane;
    }
    starts[g] = static_cast<std::uint32_t>(n);
    return g;
}

// Whether the row is all zero, 16 coefficients at a time (the scalar loop's exit mispredicted).
VOLCL_SIMD_ENCODER_TARGET
bool rowIsZeroSimd(const std::int32_t* row, std::size_t nx) {
    for (std::size_t x = 0; x < nx; x += 16) {
        const auto valid = static_cast<__mmask16>(nx - x >= 16 ? 0xFFFFu : (1u << (nx - x)) - 1u);
        const __m512i v = _mm512_maskz_loadu_epi32(valid, row + x);
        if (_mm512_test_epi32_mask(v, v) != 0) return false;
    }
    return true;
}

// The scalar coder's table lookups as arithmetic on 16 lanes (checked against the tables for every input
// class by denseEncoderArithmeticMatchesTables). symbolOf: 2 sh + (u >> sh), sh = max(k - 1, 0),
// k = floor(log2 max(u, 1)).
VOLCL_SIMD_ENCODER_TARGET inline __m512i symbolsOf(__m512i u) {
    const __m512i one = _mm512_set1_epi32(1);
    const __m512i k = _mm512_sub_epi32(_mm512_set1_epi32(31), _mm512_lzcnt_epi32(_mm512_or_si512(u, one)));
    const __m512i sh = _mm512_max_epi32(_mm512_sub_epi32(k, one), _mm512_setzero_si512());
    return _mm512_add_epi32(_mm512_add_epi32(sh, sh), _mm512_srlv_epi32(u, sh));
}
// kSymbolInfo.west[p] = 4 base(p) = min(p, 2 | (p & 1)) << max(p / 2 + 1, 2).
VOLCL_SIMD_ENCODER_TARGET inline __m512i westOf(__m512i p) {
    const __m512i one = _mm512_set1_epi32(1), two = _mm512_set1_epi32(2);
    return _mm512_sllv_epi32(_mm512_min_epu32(p, _mm512_or_si512(_mm512_and_si512(p, one), two)),
                             _mm512_max_epu32(_mm512_add_epi32(_mm512_srli_epi32(p, 1), one), two));
}
// activityContext(a): 2n + 1 + (the bit below the leading one) for bit length n + 1 >= 2, written
// 61 - 2 lz + (a >> (30 - lz)); a < 2 is its own class (the shift count is then out of range and gives 0);
// capped at 24.
VOLCL_SIMD_ENCODER_TARGET inline __m512i activityClassesOf(__m512i a) {
    const __m512i lz = _mm512_lzcnt_epi32(a);
    const __m512i cls = _mm512_add_epi32(_mm512_sub_epi32(_mm512_set1_epi32(61), _mm512_add_epi32(lz, lz)),
                                         _mm512_srlv_epi32(a, _mm512_sub_epi32(_mm512_set1_epi32(30), lz)));
    return _mm512_min_epi32(_mm512_max_epi32(cls, _mm512_min_epu32(a, _mm512_set1_epi32(1))),
                            _mm512_set1_epi32(kActivityContexts - 1));
}

// Inputs that cover every class of symbolsOf (u below 2^16, and 2^k - 1, 2^k, 2^k + 2^(k-1) - 1 and
// 2^k + 2^(k-1) up to 2^31) and of activityClassesOf (a below 2^16, the same boundaries, 2^32 - 1), each
// compared with the tables; W for every symbol.
VOLCL_SIMD_ENCODER_TARGET bool arithmeticMatchesTables() {
    std::vector<std::uint32_t> in;
    for (std::uint32_t v = 0; v < (1u << 16); ++v)
        in.push_back(v);
    for (int k = 1; k < 32; ++k) {
        const std::uint32_t p = 1u << k, h = p >> 1;
        for (const std::uint32_t v : {p - 1, p, p + h - 1, p + h})
            in.push_back(v);
    }
    in.push_back(0xFFFFFFFFu);
    while (in.size() % 16)
        in.push_back(0);
    alignas(64) std::uint32_t sym[16], cls[16], west[16];
    for (std::size_t i = 0; i < in.size(); i += 16) {
        const __m512i v = _mm512_loadu_si512(in.data() + i);
        _mm512_store_si512(sym, symbolsOf(v));
        _mm512_store_si512(cls, activityClassesOf(v));
        for (std::size_t k = 0; k < 16; ++k) {
            const std::uint32_t u = in[i + k];
            if (u < (1u << kMaxBitLength) && sym[k] != static_cast<std::uint32_t>(symbolOf(u))) return false;
            if (cls[k] != static_cast<std::uint32_t>(activityContext(u))) return false;
        }
    }
    for (std::uint32_t p = 0; p < 64; p += 16) {
        _mm512_store_si512(west, westOf(_mm512_add_epi32(_mm512_set1_epi32(static_cast<int>(p)),
                                                         _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10,
                                                                           11, 12, 13, 14, 15))));
        for (std::uint32_t k = 0; k < 16; ++k)
            if (p + k < kSymbols && west[k] != kSymbolInfo.west[p + k]) return false;
    }
    return true;
}

// encodeRow 16 coefficients at a time (same outputs): the symbol and the previous one (a shifted vector),
// W and the activity class by arithmetic (lzcnt) where encodeRow reads tables, the per non-zero outputs
// by compressing stores.
VOLCL_SIMD_ENCODER_TARGET
std::size_t encodeRowSimd(const RowJob& j, const SymbolSlots& slots, std::uint32_t* signs,
                          std::uint32_t* raws, std::size_t& rawCount, std::uint32_t& all) {
    const __m512i zero = _mm512_setzero_si512(), one = _mm512_set1_epi32(1), two = _mm512_set1_epi32(2),
                  laneBits = _mm512_set1_epi32(static_cast<int>(j.lane << kEventLaneShift)),
                  negBit = _mm512_set1_epi32(1 << 16);
    __m512i prevSym = zero, prevSign = zero, any = zero;
    // Slots of the 16 x of a step (SymbolSlots): x * rows + row below minNx, tail + x from there.
    const __m512i iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const auto rows = static_cast<int>(slots.rows);
    __m512i xs = iota, interleaved = _mm512_add_epi32(_mm512_mullo_epi32(iota, _mm512_set1_epi32(rows)),
                                                      _mm512_set1_epi32(static_cast<int>(slots.row)));
    const __m512i minNx = _mm512_set1_epi32(static_cast<int>(slots.minNx)),
                  tail = _mm512_set1_epi32(static_cast<int>(slots.tail)), sixteen = _mm512_set1_epi32(16),
                  interleavedStep = _mm512_set1_epi32(16 * rows);
    const __m512i three = _mm512_set1_epi32(3);
    std::size_t count = 0, rawN = 0;
    for (std::size_t x = 0; x < j.nx; x += 16) {
        const auto valid = static_cast<__mmask16>(j.nx - x >= 16 ? 0xFFFFu : (1u << (j.nx - x)) - 1u);
        const __m512i v = _mm512_maskz_loadu_epi32(valid, j.row + x);
        const __m512i u = _mm512_abs_epi32(v);
        any = _mm512_or_si512(any, u);
        const __m512i sym = symbolsOf(u);
        // W from the previous symbol (the previous lane, or the last of the previous step), the activity
        // sum in u32 as the scalar one.
        const __m512i west = westOf(_mm512_alignr_epi32(sym, prevSym, 15));
        prevSym = sym;
        const __m512i cls =
            activityClassesOf(_mm512_add_epi32(_mm512_maskz_loadu_epi32(valid, j.activity + x), west));
        const __m512i slot = _mm512_mask_add_epi32(interleaved, _mm512_cmpge_epu32_mask(xs, minNx), xs, tail);
        _mm512_mask_i32scatter_epi32(
            slots.events, valid, slot,
            _mm512_or_si512(_mm512_add_epi32(_mm512_slli_epi32(cls, 6), sym), laneBits), 4);
        xs = _mm512_add_epi32(xs, sixteen);
        interleaved = _mm512_add_epi32(interleaved, interleavedStep);
        _mm512_mask_cvtepi32_storeu_epi8(j.syms + x, valid, sym);
        _mm512_mask_storeu_epi32(j.mag + x, valid, u);
        const __mmask16 neg = _mm512_cmplt_epi32_mask(v, zero);
        const __mmask16 nz = _mm512_mask_cmpneq_epi32_mask(valid, v, zero);
        const __m512i sign = _mm512_mask_mov_epi32(_mm512_maskz_mov_epi32(nz, one), neg, two);
        _mm512_mask_cvtepi32_storeu_epi8(j.sgn + x, valid, sign);
        // Per non-zero: sign context (neighbour part + previous coefficient's sign class) | negative << 16;
        // per symbol >= 4: its sym / 2 - 1 raw bits with a 1 above.
        const __m512i base = _mm512_cvtepu16_epi32(
            _mm256_maskz_loadu_epi16(valid, reinterpret_cast<const __m256i*>(j.signBase + x)));
        const __m512i sctx = _mm512_add_epi32(base, _mm512_alignr_epi32(sign, prevSign, 15));
        prevSign = sign;
        _mm512_mask_compressstoreu_epi32(signs + count, nz, _mm512_mask_or_epi32(sctx, neg, sctx, negBit));
        const __mmask16 hasRaw = _mm512_mask_cmpgt_epu32_mask(valid, sym, three);
        const __m512i top = _mm512_sllv_epi32(one, _mm512_sub_epi32(_mm512_srli_epi32(sym, 1), one));
        _mm512_mask_compressstoreu_epi32(
            raws + rawN, hasRaw, _mm512_or_si512(_mm512_and_si512(u, _mm512_sub_epi32(top, one)), top));
        count += static_cast<std::size_t>(_mm_popcnt_u32(nz));
        rawN += static_cast<std::size_t>(_mm_popcnt_u32(hasRaw));
    }
    all |= static_cast<std::uint32_t>(_mm512_reduce_or_epi32(any));
    rawCount = rawN;
    return count;
}

// The sign events of a row group in the decoder's order, as EncodeSide::rows' scalar loop: step n codes the
// n-th non-zero coefficient of every row that has one, a row per lane. The rows' models are disjoint (one
// orientation each), so one gather and one scatter per step see no conflicts; the events of a step are
// compressed in row order. Returns the end of the events written at `ev`.
VOLCL_SIMD_ENCODER_TARGET
RansEvent* signEventsSimd(const std::size_t* rowCount, const unsigned* rowLane, std::size_t nj,
                          std::size_t steps, const std::uint32_t* signCodes, std::size_t pitch,
                          BitModel* models, RansEvent* ev) {
    alignas(32) std::uint32_t count[8] = {}, bits[8] = {}, base[8] = {};
    for (std::size_t i = 0; i < nj; ++i) {
        count[i] = static_cast<std::uint32_t>(rowCount[i]);
        bits[i] = ransEvent(0, 0, true, rowLane[i]);
        base[i] = static_cast<std::uint32_t>(i * pitch);
    }
    const __m256i counts = _mm256_load_si256(reinterpret_cast<const __m256i*>(count));
    const __m256i laneBits = _mm256_load_si256(reinterpret_cast<const __m256i*>(bits));
    __m256i at = _mm256_load_si256(reinterpret_cast<const __m256i*>(base));
    const __m256i one = _mm256_set1_epi32(1), scale = _mm256_set1_epi32(kBinaryScale),
                  ctxMask = _mm256_set1_epi32(0xFFFF), negBit = _mm256_set1_epi32(1 << 16);
    __m256i step = _mm256_setzero_si256();
    auto* p0s = reinterpret_cast<int*>(models);
    for (std::size_t n = 0; n < steps; ++n) {
        const __mmask8 valid = _mm256_cmpgt_epu32_mask(counts, step);
        step = _mm256_add_epi32(step, one);
        const __m256i sc = _mm256_mmask_i32gather_epi32(_mm256_setzero_si256(), valid, at,
                                                        reinterpret_cast<const int*>(signCodes), 4);
        at = _mm256_add_epi32(at, one);
        const __m256i ctx = _mm256_and_si256(sc, ctxMask);
        const __mmask8 neg = _mm256_test_epi32_mask(sc, negBit);
        const __m256i p0 = _mm256_mmask_i32gather_epi32(_mm256_setzero_si256(), valid, ctx, p0s, 4);
        const __m256i q = _mm256_sub_epi32(scale, p0);
        const __m256i up = _mm256_add_epi32(p0, _mm256_srli_epi32(q, 5));
        const __m256i down = _mm256_sub_epi32(p0, _mm256_srli_epi32(p0, 5));
        _mm256_mask_i32scatter_epi32(p0s, valid, ctx, _mm256_mask_mov_epi32(up, neg, down), 4);
        const __m256i freq = _mm256_mask_mov_epi32(p0, neg, q);
        const __m256i e = _mm256_or_si256(
            _mm256_or_si256(_mm256_maskz_mov_epi32(neg, p0), _mm256_slli_epi32(freq, kEventFreqShift)),
            laneBits);
        _mm256_mask_compressstoreu_epi32(ev, valid, e);
        ev += _mm_popcnt_u32(valid);
    }
    return ev;
}

// The backward pass a group of events at a time, for the same stream as ransEncode: a run of events on
// distinct lanes can be coded as one step when the words it flushes go to the stream in event order,
// since each event then sees the state it sees in the one-at-a-time pass. Groups are maximal runs of
// strictly increasing lane (the walker emits row flags, symbol columns and sign steps so, up to 7 events).
// A group's events are expanded into their lanes (increasing lanes: vpexpandd with the lane mask), the
// flushed low words compressed in lane order, q = floor(s / freq) is one 52-bit multiply-high by the
// reciprocal and the new state s + start + q (2^scaleBits - freq) one multiply-add: the chain from state
// to state is compare, shift, two IFMAs (about 12 cycles) with the states in a register. `events` are
// resolved in place; 8 readable events follow them.
VOLCL_SIMD_ENCODER_TARGET
void ransEncodeSimd(std::span<RansEvent> events, int lanes, const RansEvent* codeSlots,
                    std::vector<std::uint8_t>& out) {
    // 8 spare words: a group's store writes 8 words, those below its own lie below the stream's start.
    WordBuffer wb(events.size() + 8);
    std::uint16_t* w = wb.first;
    RansEvent* ev = events.data();
    std::uint32_t* const starts = EncoderScratch::atLeast(encoderScratch().starts, events.size() + 1);
    const std::size_t groups = resolveAndGroup(ev, events.size(), codeSlots, starts);
    const __m256i one32 = _mm256_set1_epi32(1), fieldMask = _mm256_set1_epi32(kEventFieldMask),
                  freqMask = _mm256_set1_epi32(kEventFreqMask);
    const __m512i c21 = _mm512_set1_epi64(21), c11 = _mm512_set1_epi64(kTableScaleBits),
                  one = _mm512_set1_epi64(1);
    const auto* recip = reinterpret_cast<const long long*>(kReciprocal52.data());
    __m512i x = _mm512_set1_epi64(kRansLow);
    for (std::size_t g = groups; g-- > 0;) {
        // Nothing here depends on the groups after it but the states, so the loads, lane masks and
        // reciprocal lookups of the next groups overlap the state chain.
        const std::size_t start = starts[g];
        const auto len = static_cast<unsigned>(starts[g + 1] - start);
        const __m256i win = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(ev + start));
        // The group's lanes as a bit mask: a byte 1 << lane per event, summed (the lanes are distinct).
        const __m256i bits = _mm256_maskz_sllv_epi32(static_cast<__mmask8>((1u << len) - 1u), one32,
                                                     _mm256_srli_epi32(win, kEventLaneShift));
        const auto active = static_cast<__mmask8>(
            _mm_cvtsi128_si32(_mm_sad_epu8(_mm256_cvtepi32_epi8(bits), _mm_setzero_si128())));
        const __m256i e = _mm256_maskz_expand_epi32(active, win);
        const __m256i freq32 = _mm256_and_si256(_mm256_srli_epi32(e, kEventFreqShift), freqMask);
        const __m512i freq = _mm512_cvtepu32_epi64(freq32);
        const __m512i binary =
            _mm512_cvtepu32_epi64(_mm256_and_si256(_mm256_srli_epi32(e, kEventBinaryShift), one32));
        // Off the chain: the flush threshold freq << (32 - scaleBits), 2^scaleBits - freq, the reciprocal.
        const __m512i threshold = _mm512_sllv_epi64(freq, _mm512_sub_epi64(c21, binary));
        const __m512i gap = _mm512_sub_epi64(_mm512_sllv_epi64(one, _mm512_add_epi64(c11, binary)), freq);
        const __m512i m = _mm512_mask_i32gather_epi64(_mm512_setzero_si512(), active, freq32, recip, 8);
        __m512i startv = _mm512_cvtepu32_epi64(_mm256_and_si256(e, fieldMask));
        startv = _mm512_mask_add_epi64(startv, _mm512_cmpeq_epu64_mask(freq, one), startv, gap);
        // The chain: flush, divide, advance.
        const __mmask8 flush = _mm512_mask_cmpge_epu64_mask(active, x, threshold);
        const auto n = static_cast<unsigned>(_mm_popcnt_u32(flush));
        // Compressed words to the top of 8 and stored below the words so far (the 8 - n below them are
        // overwritten by earlier groups or lie in the spare words).
        const __m128i words = _mm_maskz_expand_epi16(
            static_cast<__mmask8>(0xFF00u >> n), _mm_maskz_compress_epi16(flush, _mm512_cvtepi64_epi16(x)));
        w -= n;
        _mm_storeu_si128(reinterpret_cast<__m128i*>(w + n - 8), words);
        const __m512i s = _mm512_mask_srli_epi64(x, flush, x, 16);
        const __m512i q = _mm512_madd52hi_epu64(_mm512_setzero_si512(), s, m);
        x = _mm512_mask_madd52lo_epu64(_mm512_mask_add_epi64(x, active, s, startv), active, q, gap);
    }
    wb.first = w;
    alignas(64) std::uint64_t states[8];
    _mm512_store_si512(states, x);
    std::uint32_t x32[kMaxLanes];
    for (int lane = 0; lane < kMaxLanes; ++lane)
        x32[lane] = static_cast<std::uint32_t>(states[lane]);
    putStream(x32, lanes, wb, out);
}
#pragma GCC diagnostic pop

constexpr DenseEncoderKernels kAvx512{rowIsZeroSimd, encodeRowSimd, signEventsSimd, ransEncodeSimd,
                                      arithmeticMatchesTables};

} // namespace

const DenseEncoderKernels* avx512DenseEncoderKernels() noexcept {
    static const bool ok = cpuHasDenseAvx512() && __builtin_cpu_supports("avx512ifma");
    return ok ? &kAvx512 : nullptr;
}

} // namespace volcl::entropy
