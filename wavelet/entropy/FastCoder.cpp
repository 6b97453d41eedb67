// The fast entropy coder (libzstd over byte planes of sign-folded coefficients, zero blocks skipped).
#include "wavelet/entropy/FastCoder.hpp"

#include "core/Error.hpp"

#include <zstd.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include <algorithm>
#include <cstring>
#include <memory>
#include <string>
#include <utility>

namespace volcl::entropy {

namespace {

// ------------------------------------------------------------------------------ fast mode

// zstd's fastest strategy (level 1) with the longest minimum match (7) and the smallest hash table (64
// entries): on sign-folded coefficient planes the matches that a larger table finds are mostly short
// repeats that cost more than the Huffman-coded literals they replace, so fewer matches give smaller
// sections and a faster coder both ways (entropy-only, BrainWeb fast, against plain level 1: bytes -5.0 %
// at 2 bpv, -5.5 % at 1 bpv, -4.4 % lossless, ch2better -5.8 %, walnut -0.3 %; zstd encode time -20 to
// -35 %, decode -5 to -15 %). Plain zstd frames: the decoder needs no parameters.
void setFastParameters(ZSTD_CCtx* c) {
    const std::pair<ZSTD_cParameter, int> params[] = {{ZSTD_c_compressionLevel, 1},
                                                      {ZSTD_c_strategy, ZSTD_fast},
                                                      {ZSTD_c_minMatch, 7},
                                                      {ZSTD_c_hashLog, 6}};
    for (const auto& [param, value] : params) {
        const std::size_t r = ZSTD_CCtx_setParameter(c, param, value);
        if (ZSTD_isError(r))
            throw Error(std::string("zstd: cannot set a parameter: ") + ZSTD_getErrorName(r));
    }
}

// Per-thread zstd contexts and byte-plane buffer, reused across sections: a fresh context per call (what
// ZSTD_compress/ZSTD_decompress make) and a zero-filled buffer per section cost more than coding a
// mostly-zero lossy section.
struct FastScratch {
    struct FreeC {
        void operator()(ZSTD_CCtx* c) const noexcept { ZSTD_freeCCtx(c); }
    };
    struct FreeD {
        void operator()(ZSTD_DCtx* d) const noexcept { ZSTD_freeDCtx(d); }
    };
    std::unique_ptr<ZSTD_CCtx, FreeC> cctx{ZSTD_createCCtx()};
    std::unique_ptr<ZSTD_DCtx, FreeD> dctx{ZSTD_createDCtx()};
    std::vector<std::uint8_t> planes, packed, frame;
    FastScratch() {
        if (cctx) setFastParameters(cctx.get());
    }
    // The buffers only grow: a vector resized down for a small section and up again for the next large
    // one zero-fills the difference, which was about 1/10 of the fast coder's instructions at 2 bpv.
    static std::uint8_t* atLeast(std::vector<std::uint8_t>& v, std::size_t n) {
        if (v.size() < n) v.resize(n);
        return v.data();
    }
};
FastScratch& fastScratch() {
    thread_local FastScratch s;
    if (!s.cctx || !s.dctx) throw Error("zstd: out of memory for a coding context");
    return s;
}

std::uint32_t foldSign(std::int32_t v) {
    return (static_cast<std::uint32_t>(v) << 1) ^ static_cast<std::uint32_t>(v >> 31);
}

// Byte planes First..Planes-1 of the sign-folded coefficients, plane p at p * count; rows written with one
// loop per plane.
template <int First, int Planes>
void foldIntoPlanes(const std::int32_t* c, const std::vector<SubbandBox>& sec, Dims brick, std::uint8_t* raw,
                    std::size_t count) {
    std::size_t i = 0;
    forEachSectionRow(c, sec, brick, [&](const std::int32_t* row, std::size_t len, const SubbandBox&) {
        for (int p = First; p < Planes; ++p) {
            std::uint8_t* dst = raw + std::size_t(p) * count + i;
            for (std::size_t k = 0; k < len; ++k)
                dst[k] = static_cast<std::uint8_t>(foldSign(row[k]) >> (8 * p));
        }
        i += len;
    });
}

// Rows of sign-folded byte planes back to indices, or with `dq` straight to dequantised values (float bit
// patterns) in the same loop: |q| = (f + 1) >> 1 and the sign is f's low bit, so the value is
// dequantiseRow's (|q| + bias) * step with that sign bit or'ed in, 0 for f = 0; bit-identical to it (one
// pass per row instead of an index pass and a dequantisation pass; the loops vectorise on SSE2).
// One row of Planes byte planes (plane p at src + p * count) to dequantised values or indices. Restrict
// pointers: without them the byte loads may alias the stores, and each row paid a run-time overlap check.
template <int Planes>
std::uint32_t foldedAt(const std::uint8_t* __restrict src, std::size_t count, std::size_t k) {
    std::uint32_t f = 0;
    for (int p = 0; p < Planes; ++p)
        f |= static_cast<std::uint32_t>(src[std::size_t(p) * count + k]) << (8 * p);
    return f;
}
template <int Planes>
void dequantiseFoldedRow(const std::uint8_t* __restrict src, std::size_t count, std::uint32_t* __restrict out,
                         std::size_t len, float s, float bs) {
    for (std::size_t k = 0; k < len; ++k) {
        const std::uint32_t f = foldedAt<Planes>(src, count, k);
        const float m = static_cast<float>(static_cast<std::int32_t>((f + 1) >> 1)) * s + bs;
        const std::uint32_t r = std::bit_cast<std::uint32_t>(m) | (f << 31);
        out[k] = f == 0 ? 0u : r;
    }
}
template <int Planes>
void unfoldFoldedRow(const std::uint8_t* __restrict src, std::size_t count, std::int32_t* __restrict out,
                     std::size_t len) {
    for (std::size_t k = 0; k < len; ++k) {
        const std::uint32_t f = foldedAt<Planes>(src, count, k);
        out[k] = static_cast<std::int32_t>((f >> 1) ^ (0u - (f & 1u)));
    }
}

// Rows of sign-folded byte planes back to indices, or with `dq` straight to dequantised values (float bit
// patterns) in the same loop: |q| = (f + 1) >> 1 and the sign is f's low bit, so the value is
// dequantiseRow's (|q| + bias) * step with that sign bit or'ed in, 0 for f = 0; bit-identical to it (one
// pass per row instead of an index pass and a dequantisation pass; the loops vectorise on SSE2).
template <int Planes>
void unfoldFromPlanes(const std::uint8_t* raw, std::size_t count, std::int32_t* c,
                      const std::vector<SubbandBox>& sec, Dims brick, const Dequantiser* dq) {
    std::size_t i = 0;
    forEachSectionRow(c, sec, brick, [&](std::int32_t* row, std::size_t len, const SubbandBox& b) {
        if (dq) {
            const double step = dq->step(b);
            dequantiseFoldedRow<Planes>(raw + i, count, reinterpret_cast<std::uint32_t*>(row), len,
                                        static_cast<float>(step), static_cast<float>(dq->bias * step));
        } else {
            unfoldFoldedRow<Planes>(raw + i, count, row, len);
        }
        i += len;
    });
}

template <class Fn> void withPlanes(std::size_t planes, Fn fn) {
    switch (planes) {
    case 1:
        return fn(std::integral_constant<int, 1>{});
    case 2:
        return fn(std::integral_constant<int, 2>{});
    case 3:
        return fn(std::integral_constant<int, 3>{});
    default:
        return fn(std::integral_constant<int, 4>{});
    }
}

// Zero-block skipping: the plane bytes as 4-byte blocks, a bitmap with one bit per block (bit k % 8 of byte
// k / 8: block k is not all zero) followed by the non-zero blocks only, all in one zstd frame. Lossy 1-2 bpv
// sections are mostly zero blocks; zstd then codes a short bitmap and the blocks that carry information
// instead of zero runs between them: BrainWeb fast, section bytes -1.9 % at 2 bpv and -5.3 % at 1 bpv, zstd
// CPU time about -40 % both ways (4-byte blocks beat 8: +2.0 % and +4.4 % bytes, and 16 or 32). Sections
// with few zero blocks keep the plain layout (the bitmap is then a cost: lossless BrainWeb +0.8 %).
constexpr std::uint8_t kZeroSkip = 0x80; // flag in the section's first byte, beside the plane count
constexpr std::size_t kSkipBlock = 4;

std::uint32_t load32(const std::uint8_t* p) {
    std::uint32_t v;
    std::memcpy(&v, p, 4);
    return v;
}
void store32(std::uint8_t* p, std::uint32_t v) {
    std::memcpy(p, &v, 4);
}

// Writes the bitmap and the non-zero blocks of `bytes` (`blocks` whole blocks, readable) to `out`, which has
// room for the bitmap and every block; returns the bytes written. Branch-free per block: each block is
// stored and the output advances past it only if it is non-zero.
std::size_t packNonZeroBlocks(const std::uint8_t* bytes, std::size_t blocks, std::uint8_t* out) {
    const std::size_t mapBytes = (blocks + 7) / 8;
    std::uint8_t* pk = out + mapBytes;
    for (std::size_t m = 0; m < mapBytes; ++m) {
        std::uint32_t bits = 0;
        const std::size_t end = std::min<std::size_t>(8, blocks - 8 * m);
        if (end == 8) { // eight zero blocks at once: the common case in lossy sections
            std::uint64_t w[4];
            std::memcpy(w, bytes + kSkipBlock * 8 * m, sizeof w);
            if ((w[0] | w[1] | w[2] | w[3]) == 0) {
                out[m] = 0;
                continue;
            }
        }
        for (std::size_t j = 0; j < end; ++j) {
            const std::uint32_t w = load32(bytes + kSkipBlock * (8 * m + j));
            const std::uint32_t nz = w != 0;
            store32(pk, w);
            pk += kSkipBlock * nz;
            bits |= nz << j;
        }
        out[m] = static_cast<std::uint8_t>(bits);
    }
    return static_cast<std::size_t>(pk - out);
}

// Inverse of packNonZeroBlocks into `bytes` (`blocks` whole blocks); `in` holds `size` bytes and 4 readable
// bytes after them. Returns false if the bitmap and the size disagree (bits past the last block set, or a
// block count that does not match the data).
bool unpackNonZeroBlocks(const std::uint8_t* in, std::size_t size, std::size_t blocks, std::uint8_t* bytes) {
    const std::size_t mapBytes = (blocks + 7) / 8;
    if (size < mapBytes) return false;
    if (blocks % 8 && in[mapBytes - 1] >> (blocks % 8)) return false;
    // Set bits counted 8 map bytes at a time with SWAR arithmetic: the build targets baseline x86-64, where
    // std::popcount is a libgcc call (it was one call per map byte: ~2 % of a BrainWeb 2 bpv decode).
    const auto bitCount = [](std::uint64_t v) {
        v -= (v >> 1) & 0x5555555555555555u;
        v = (v & 0x3333333333333333u) + ((v >> 2) & 0x3333333333333333u);
        v = (v + (v >> 4)) & 0x0F0F0F0F0F0F0F0Fu;
        return static_cast<std::size_t>((v * 0x0101010101010101u) >> 56);
    };
    std::size_t set = 0, m = 0;
    for (; m + 8 <= mapBytes; m += 8) {
        std::uint64_t w;
        std::memcpy(&w, in + m, 8);
        set += bitCount(w);
    }
    for (; m < mapBytes; ++m)
        set += bitCount(in[m]);
    if (size - mapBytes != kSkipBlock * set) return false;
    const std::uint8_t* pk = in + mapBytes;
    for (std::size_t m = 0; m < mapBytes; ++m) {
        const std::uint32_t bits = in[m];
        std::uint8_t* dst = bytes + kSkipBlock * 8 * m;
        const std::size_t end = std::min<std::size_t>(8, blocks - 8 * m);
        if (end == 8 && (bits == 0 || bits == 0xFF)) { // fixed-size copies, inlined
            if (bits == 0) {
                std::memset(dst, 0, kSkipBlock * 8);
            } else {
                std::memcpy(dst, pk, kSkipBlock * 8);
                pk += kSkipBlock * 8;
            }
            continue;
        }
        for (std::size_t j = 0; j < end; ++j) {
            const std::uint32_t nz = (bits >> j) & 1u;
            store32(dst + kSkipBlock * j, load32(pk) & (0u - nz));
            pk += kSkipBlock * nz;
        }
    }
    return true;
}

} // namespace

void encodeFast(std::span<const std::int32_t> c, const std::vector<SubbandBox>& sec, Dims brick,
                std::vector<std::uint8_t>& out) {
    std::size_t count = 0;
    for (const SubbandBox& b : sec)
        count += b.count();
    if (count == 0) return;
    // Plane 0 is written in the pass that finds the plane count (the OR of the folded values has the same
    // highest bit as their maximum, and vectorises on SSE2): lossy sections mostly need that plane only.
    FastScratch& s = fastScratch();
    std::uint8_t* raw = FastScratch::atLeast(s.planes, count + kSkipBlock);
    std::uint32_t bits = 0;
    std::size_t i = 0;
    forEachSectionRow(c.data(), sec, brick, [&](const std::int32_t* row, std::size_t len, const SubbandBox&) {
        std::uint32_t o = 0;
        std::uint8_t* dst = raw + i;
        std::size_t k = 0;
#ifdef __SSE2__
        // 16 at a time by hand: fold, OR into the plane-count mask, low bytes out; 3 % fewer encoder
        // instructions than GCC's vectorised loop, whose entry and exit cost much on 32-long rows (the same
        // change to the decoder's dequantising loop saved 0.2 % and was left out).
        __m128i vo = _mm_setzero_si128();
        const __m128i lowByte = _mm_set1_epi32(0xFF);
        for (; k + 16 <= len; k += 16) {
            __m128i f[4];
            for (int j = 0; j < 4; ++j) {
                const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + k + 4 * j));
                f[j] = _mm_xor_si128(_mm_slli_epi32(v, 1), _mm_srai_epi32(v, 31));
                vo = _mm_or_si128(vo, f[j]);
                f[j] = _mm_and_si128(f[j], lowByte);
            }
            _mm_storeu_si128(reinterpret_cast<__m128i*>(dst + k),
                             _mm_packus_epi16(_mm_packs_epi32(f[0], f[1]), _mm_packs_epi32(f[2], f[3])));
        }
        vo = _mm_or_si128(vo, _mm_srli_si128(vo, 8));
        vo = _mm_or_si128(vo, _mm_srli_si128(vo, 4));
        o = static_cast<std::uint32_t>(_mm_cvtsi128_si32(vo));
#endif
        for (; k < len; ++k) {
            const std::uint32_t f = foldSign(row[k]);
            o |= f;
            dst[k] = static_cast<std::uint8_t>(f);
        }
        bits |= o;
        i += len;
    });
    const std::size_t planes = bits < 0x100u ? 1 : bits < 0x10000u ? 2 : bits < 0x1000000u ? 3 : 4;
    const std::size_t total = count * planes, blocks = (total + kSkipBlock - 1) / kSkipBlock;
    if (planes > 1) {
        raw = FastScratch::atLeast(s.planes, total + kSkipBlock); // keeps plane 0
        withPlanes(planes, [&](auto p) { foldIntoPlanes<1, p()>(c.data(), sec, brick, raw, count); });
    }
    // Whole blocks: the plane bytes padded with zeros to a multiple of the block size.
    std::fill(raw + total, raw + blocks * kSkipBlock, std::uint8_t(0));
    std::uint8_t* packed =
        FastScratch::atLeast(s.packed, (blocks + 7) / 8 + blocks * kSkipBlock + kSkipBlock);
    const std::size_t packedSize = packNonZeroBlocks(raw, blocks, packed);
    // Skip zero blocks when that removes at least 1/8 of the bytes (lossless sections rarely do).
    const bool skip = 8 * packedSize <= 7 * total;
    const std::uint8_t* src = skip ? packed : raw;
    const std::size_t srcSize = skip ? packedSize : total;
    // Compressed into scratch and appended: growing `out` by the bound would zero-fill it first.
    const std::size_t bound = ZSTD_compressBound(srcSize);
    std::uint8_t* frame = FastScratch::atLeast(s.frame, bound);
    // The parameters set on the context stay for every frame (ZSTD_compress2 resets only the session).
    const std::size_t n = ZSTD_compress2(s.cctx.get(), frame, bound, src, srcSize);
    if (ZSTD_isError(n)) throw Error(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    out.push_back(static_cast<std::uint8_t>(planes | (skip ? kZeroSkip : 0)));
    out.insert(out.end(), frame, frame + n);
}

void decodeFast(std::span<const std::uint8_t> in, std::span<std::int32_t> c,
                const std::vector<SubbandBox>& sec, Dims brick, const char* what, const Dequantiser* dq) {
    std::size_t count = 0;
    for (const SubbandBox& b : sec)
        count += b.count();
    if (count == 0) {
        if (!in.empty()) throw IoError(std::string(what) + ": unexpected data in an empty section");
        return;
    }
    const std::size_t planes = in.empty() ? 0 : in[0] & ~kZeroSkip;
    if (in.size() < 2 || planes < 1 || planes > 4)
        throw IoError(std::string(what) + ": invalid fast-mode section");
    FastScratch& s = fastScratch();
    const std::size_t total = count * planes, blocks = (total + kSkipBlock - 1) / kSkipBlock;
    std::uint8_t* raw = FastScratch::atLeast(s.planes, blocks * kSkipBlock);
    if (in[0] & kZeroSkip) {
        const std::size_t capacity = (blocks + 7) / 8 + blocks * kSkipBlock;
        std::uint8_t* packed = FastScratch::atLeast(s.packed, capacity + kSkipBlock);
        const std::size_t n =
            ZSTD_decompressDCtx(s.dctx.get(), packed, capacity, in.data() + 1, in.size() - 1);
        if (ZSTD_isError(n) || !unpackNonZeroBlocks(packed, n, blocks, raw))
            throw IoError(std::string(what) + ": zstd section does not decode to its size");
    } else {
        const std::size_t n = ZSTD_decompressDCtx(s.dctx.get(), raw, total, in.data() + 1, in.size() - 1);
        if (ZSTD_isError(n) || n != total)
            throw IoError(std::string(what) + ": zstd section does not decode to its size");
    }
    withPlanes(planes, [&](auto p) { unfoldFromPlanes<p()>(raw, count, c.data(), sec, brick, dq); });
}

} // namespace volcl::entropy
