// Entropy coders for wavelet coefficient sections: dense (context-modelled interleaved rANS) and fast
// (libzstd over byte planes).
//
// Dense mode is a hand-written rANS coder (one 32-bit state per subband of a section, up to 7, sharing one
// stream of 16-bit words) because the ratio comes from the coefficient model and no Debian library takes caller-defined
// contexts: zstd, xz and brotli model bytes, libzstd's FSE/huff0 are not public API, and htscodecs' rANS
// (libhtscodecs-dev) has order-0/1 byte models only. The model mixes two kinds of decisions in one stream:
// magnitude symbols from static per-section tables (chosen by a context of neighbour and parent
// magnitudes, tables sent with the section) and adaptive binary decisions (row "all zero" flags and signs,
// whose contexts are too many for sent tables).
// Fast mode uses libzstd.
#include "wavelet/EntropyCoder.hpp"

#include "host/Error.hpp"

#include <zstd.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>

#if defined(__x86_64__) && defined(__GNUC__)
#define VOLCL_DENSE_SIMD 1
#include <immintrin.h>
#endif

namespace volcl {

std::vector<std::vector<SubbandBox>> sectionLayout(Dims brick, int levels) {
    std::vector<std::vector<SubbandBox>> layout(static_cast<std::size_t>(levels) + 1);
    const Dims low = [&] {
        auto shrink = [levels](std::size_t n) { return ((n - 1) >> levels) + 1; };
        return Dims{shrink(brick.x), shrink(brick.y), shrink(brick.z)};
    }();
    layout[0].push_back({0, low.x, 0, low.y, 0, low.z, 0, 0});
    for (int l = levels; l >= 1; --l) {
        auto shrink = [](std::size_t n, int k) { return ((n - 1) >> k) + 1; };
        const Dims p{shrink(brick.x, l - 1), shrink(brick.y, l - 1), shrink(brick.z, l - 1)};
        const Dims q{shrink(brick.x, l), shrink(brick.y, l), shrink(brick.z, l)};
        auto& sec = layout[static_cast<std::size_t>(levels - l + 1)];
        for (int o = 1; o < 8; ++o) {
            SubbandBox b;
            b.level = l;
            b.orient = o;
            b.x0 = (o & 1) ? q.x : 0;
            b.x1 = (o & 1) ? p.x : q.x;
            b.y0 = (o & 2) ? q.y : 0;
            b.y1 = (o & 2) ? p.y : q.y;
            b.z0 = (o & 4) ? q.z : 0;
            b.z1 = (o & 4) ? p.z : q.z;
            if (b.count() > 0) sec.push_back(b);
        }
    }
    return layout;
}

namespace {

[[noreturn]] void corrupt(const char* what, const char* why) {
    throw IoError(std::string(what) + ": " + why + " (corrupted data)");
}

// Sign-mask arithmetic: GCC compiles `v < 0 ? -v : v` to a jump here, mispredicted on random signs.
inline std::uint32_t magnitude(std::int32_t v) {
    const auto m = static_cast<std::uint32_t>(v >> 31);
    return (static_cast<std::uint32_t>(v) ^ m) - m;
}

// ------------------------------------------------------------------------------ raw bit streams

// Low mantissa bits are nearly equiprobable: they go to a plain bit stream, no modelling.
class BitWriter {
public:
    void put(std::uint32_t v, int n) {
        acc_ |= std::uint64_t(v) << fill_;
        fill_ += n;
        if (fill_ >= 32) {
            const auto w = static_cast<std::uint32_t>(acc_);
            const auto* p = reinterpret_cast<const std::uint8_t*>(&w);
            bytes.insert(bytes.end(), p, p + 4);
            acc_ >>= 32;
            fill_ -= 32;
        }
    }
    void finish() {
        while (fill_ > 0) {
            bytes.push_back(static_cast<std::uint8_t>(acc_));
            acc_ >>= 8;
            fill_ -= 8;
        }
        acc_ = 0;
        fill_ = 0;
    }
    std::vector<std::uint8_t> bytes;

private:
    std::uint64_t acc_ = 0;
    int fill_ = 0;
};

// The encoder's raw mantissa bits, the same bytes as BitWriter without its jump: each put stores 8 bytes
// and advances by the whole bytes filled. Values come with a 1 above their bits, which gives their length.
class RawWriter {
public:
    /// Writes into `bytes` from its start (its size is only grown).
    explicit RawWriter(std::vector<std::uint8_t>& bytes) : bytes_(bytes) {}
    /// Room for n more values.
    void reserve(std::size_t n) {
        const std::size_t need = pos_ + 4 * n + 16;
        if (bytes_.size() < need) bytes_.resize(std::max(need, 2 * bytes_.size()));
    }
    /// `count` values, each 1 << n | (n bits to write) with n <= 28, two per store: the 8-byte
    /// accumulator takes the fill (< 8 bits) and 56 more. State in locals: the byte stores may alias the
    /// members.
    void put(const std::uint32_t* codes, std::size_t count) {
        reserve(count);
        std::uint8_t* const out = bytes_.data();
        std::size_t pos = pos_;
        std::uint64_t acc = acc_;
        unsigned fill = fill_;
        for (std::size_t n = 0; n < count; n += 2) {
            const std::uint32_t code0 = codes[n], code1 = n + 1 < count ? codes[n + 1] : 1u;
            const unsigned n0 = 31u - static_cast<unsigned>(__builtin_clz(code0)); // codes are >= 1
            const unsigned n1 = 31u - static_cast<unsigned>(__builtin_clz(code1));
            const std::uint64_t bits = (code0 ^ (1u << n0)) | std::uint64_t(code1 ^ (1u << n1)) << n0;
            acc |= bits << fill;
            fill += n0 + n1;
            std::memcpy(out + pos, &acc, 8);
            const unsigned whole = fill >> 3; // at most 7
            pos += whole;
            acc >>= 8 * whole;
            fill &= 7;
        }
        pos_ = pos;
        acc_ = acc;
        fill_ = fill;
    }
    std::span<const std::uint8_t> finish() {
        reserve(0);
        if (fill_ > 0) bytes_[pos_++] = static_cast<std::uint8_t>(acc_);
        acc_ = 0;
        fill_ = 0;
        return {bytes_.data(), pos_};
    }

private:
    std::vector<std::uint8_t>& bytes_;
    std::size_t pos_ = 0;
    std::uint64_t acc_ = 0;
    unsigned fill_ = 0;
};

// Reads up to 32 bits at a time; past the end it delivers zeros and remembers the overrun.
class BitReader {
public:
    explicit BitReader(std::span<const std::uint8_t> in) : p_(in.data()), end_(in.data() + in.size()) {}
    std::uint32_t get(int n) {
        if (fill_ < n) refill(n);
        const auto v = static_cast<std::uint32_t>(acc_ & ((std::uint64_t(1) << n) - 1));
        acc_ >>= n;
        fill_ -= n;
        return v;
    }
    /// True when every byte was consumed, no more, and the unused bits of the last byte are zero.
    bool exact() const noexcept { return overrun_ == 0 && p_ == end_ && fill_ < 8 && acc_ == 0; }

private:
    void refill(int n) {
        if (end_ - p_ >= 4) {
            std::uint32_t w;
            std::memcpy(&w, p_, 4);
            p_ += 4;
            acc_ |= std::uint64_t(w) << fill_;
            fill_ += 32;
            return;
        }
        while (fill_ < n) {
            if (p_ < end_)
                acc_ |= std::uint64_t(*p_++) << fill_;
            else
                ++overrun_;
            fill_ += 8;
        }
    }
    const std::uint8_t* p_;
    const std::uint8_t* end_;
    std::uint64_t acc_ = 0;
    int fill_ = 0;
    std::size_t overrun_ = 0;
};

// A copy of `in` followed by `pad` zero bytes: the stream readers load whole words at clamped positions.
std::vector<std::uint8_t> zeroPadded(std::span<const std::uint8_t> in, std::size_t pad) {
    std::vector<std::uint8_t> b(in.size() + pad, 0);
    std::copy(in.begin(), in.end(), b.begin());
    return b;
}

// Branch-free reader for the raw mantissa bits (up to 28 per call): it reads from a copy of the stream
// with 8 zero bytes of padding (made by padded()), so every read is one unaligned 8-byte load; positions
// past the end are clamped to the padding and reported by exact(). Cheap to copy (no ownership).
class RawReader {
public:
    static std::vector<std::uint8_t> padded(std::span<const std::uint8_t> in) { return zeroPadded(in, 8); }
    /// `bytes` comes from padded(); `size` is the unpadded length.
    RawReader(const std::vector<std::uint8_t>& bytes, std::size_t size) : data_(bytes.data()), size_(size) {}
    std::uint32_t get(unsigned n) noexcept {
        const std::size_t byte = std::min<std::size_t>(bitPos_ >> 3, size_);
        std::uint64_t w;
        std::memcpy(&w, data_ + byte, 8);
        const unsigned shift = static_cast<unsigned>(bitPos_ & 7);
        bitPos_ += n;
        return static_cast<std::uint32_t>((w >> shift) & ((std::uint64_t(1) << n) - 1));
    }
    /// True when the bits read end in the last byte and the bits after them are zero.
    bool exact() const noexcept {
        if ((bitPos_ + 7) / 8 != size_) return false;
        return (bitPos_ & 7) == 0 || (data_[size_ - 1] >> (bitPos_ & 7)) == 0;
    }

private:
    const std::uint8_t* data_;
    std::size_t size_;
    std::size_t bitPos_ = 0;
};

// ------------------------------------------------------------------------------ rANS

// One state per subband of a section (up to 7) shares one stream of 16-bit words: the subbands of a section
// depend on each other only through the previous section, so the decoder works on the same row of every
// subband at once and their serial symbol chains overlap in the out-of-order core. States live in
// [2^16, 2^32).
constexpr std::uint32_t kRansLow = 1u << 16;
constexpr int kMaxLanes = 7;
constexpr int kBinaryScaleBits = 12; // adaptive binary decisions
constexpr std::uint32_t kBinaryScale = 1u << kBinaryScaleBits;
// Magnitude tables use 11 bits: the decoder's 25 slot-to-symbol tables (50 KB) then stay near L1.
constexpr int kTableScaleBits = 11;
constexpr std::uint32_t kTableScale = 1u << kTableScaleBits;

// LEB128 varints for sizes and final states.
void putVarint(std::vector<std::uint8_t>& out, std::uint64_t v) {
    while (v >= 0x80) {
        out.push_back(static_cast<std::uint8_t>(v | 0x80));
        v >>= 7;
    }
    out.push_back(static_cast<std::uint8_t>(v));
}
/// Reads a varint of at most 5 bytes at `pos`; false when it is cut off or longer.
bool getVarint(std::span<const std::uint8_t> in, std::size_t& pos, std::uint64_t& v) {
    v = 0;
    for (int i = 0; i < 5; ++i) {
        if (pos >= in.size()) return false;
        const std::uint8_t b = in[pos++];
        v |= std::uint64_t(b & 0x7F) << (7 * i);
        if (!(b & 0x80)) return true;
    }
    return false;
}

// One coded decision, packed in 4 bytes (the encoder keeps a section's events, up to ~2 MB with 6-byte
// ones, beside the 1 MB brick in L2): slots [start, start + freq) out of 2^scaleBits on state `lane`.
// Bits 0-11 start, 12-24 freq, bit 25 set for the 12-bit scale of binary decisions (else 11 bits, the
// tables'), bits 29-31 the lane. A pending magnitude symbol has freq 0 and its code (context * 64 +
// symbol, below 1600) in the start bits; the lane in the top bits lets the SIMD pass find groups of
// distinct lanes with one shift.
using RansEvent = std::uint32_t;
constexpr int kEventFreqShift = 12, kEventBinaryShift = 25, kEventLaneShift = 29;
constexpr RansEvent kEventFieldMask = 0xFFF, kEventFreqMask = 0x1FFF;
constexpr RansEvent ransEvent(std::uint32_t start, std::uint32_t freq, bool binary, unsigned lane) {
    return start | freq << kEventFreqShift | std::uint32_t(binary) << kEventBinaryShift | lane << kEventLaneShift;
}
constexpr RansEvent pendingEvent(std::uint32_t code, unsigned lane) {
    return code | lane << kEventLaneShift;
}

// Encodes events given in decoding order; the rANS encoder runs backwards, so they are collected first.
// Appends the stream to `out`.
// ceil(2^64 / f) for f in [2, 4096] (0 for f < 2): floor(x / f) = high 64 bits of x * that for any 32-bit x,
// since the rounding error stays below 2^-32 and x / f is at least 1/f < 2^-12 short of the next integer. A
// multiplication instead of a division in the encoder's serial chain.
__extension__ using Uint128 = unsigned __int128; // GCC and Clang
constexpr std::array<std::uint64_t, 4097> kReciprocal = [] {
    std::array<std::uint64_t, 4097> r{};
    for (std::uint64_t f = 2; f <= 4096; ++f)
        r[f] = ~std::uint64_t(0) / f + 1;
    return r;
}();
// The encoder's buffers, per thread and reused across sections: they only grow, so that a section costs
// no allocation, page faults or zero fill (per section they were several percent of the encoder's time).
struct EncoderScratch {
    std::vector<RansEvent> events;
    std::vector<std::uint32_t> signCodes, rawCodes, starts;
    std::vector<std::uint16_t> words;
    std::vector<std::uint8_t> raw;
    template <class T> static T* atLeast(std::vector<T>& v, std::size_t n) {
        if (v.size() < n) v.resize(std::max(n, v.size() + v.size() / 2));
        return v.data();
    }
};
EncoderScratch& encoderScratch() {
    thread_local EncoderScratch s;
    return s;
}
// The encoder's word buffer: filled from the end towards the start (the backward pass meets the words in
// reverse stream order), so the stream is [first, end) when the pass is done. Room for `words` words and
// one spare below them.
struct WordBuffer {
    std::uint16_t* end;
    std::uint16_t* first;
    explicit WordBuffer(std::size_t words)
        : end(EncoderScratch::atLeast(encoderScratch().words, words + 1) + words + 1), first(end) {}
};
// Final states as varints of x - 2^16 (an unused lane costs one byte), then the words.
void putStream(const std::uint32_t* x, int lanes, const WordBuffer& wb, std::vector<std::uint8_t>& out) {
    for (int lane = 0; lane < lanes; ++lane)
        putVarint(out, x[lane] - kRansLow);
    const std::uint16_t* end = wb.end;
    const std::size_t base = out.size();
    out.resize(base + 2 * static_cast<std::size_t>(end - wb.first));
    std::uint8_t* p = out.data() + base;
    for (const std::uint16_t* w = wb.first; w < end; ++w, p += 2) {
        p[0] = static_cast<std::uint8_t>(*w);
        p[1] = static_cast<std::uint8_t>(*w >> 8);
    }
}
// The scalar backward pass (the reference for the SIMD one). Pending events take their slots from
// `codeSlots` (per code, an event without lane).
void ransEncode(std::span<const RansEvent> events, int lanes, const RansEvent* codeSlots,
                std::vector<std::uint8_t>& out) {
    WordBuffer wb(events.size());
    std::uint16_t* w = wb.first;
    std::uint32_t x[kMaxLanes];
    std::fill(x, x + kMaxLanes, kRansLow);
    for (std::size_t k = events.size(); k-- > 0;) {
        const RansEvent raw = events[k];
        const unsigned lane = raw >> kEventLaneShift;
        const RansEvent e = (raw >> kEventFreqShift & kEventFreqMask) == 0 ? codeSlots[raw & kEventFieldMask] : raw;
        const std::uint32_t start = e & kEventFieldMask, freq = e >> kEventFreqShift & kEventFreqMask;
        const int scaleBits = kTableScaleBits + static_cast<int>(e >> kEventBinaryShift & 1u);
        std::uint32_t s = x[lane];
        // At most one 16-bit word per event: states stay below 2^32 and freq >= 1.
        const bool flush = std::uint64_t(s) >= (std::uint64_t(freq) << (32 - scaleBits));
        w[-1] = static_cast<std::uint16_t>(s); // without a flush a later word overwrites it (one spare word)
        w -= flush;
        s >>= 16 * flush;
        const auto q = freq == 1 ? s
                                 : static_cast<std::uint32_t>(
                                       (static_cast<Uint128>(s) * kReciprocal[freq]) >> 64);
        x[lane] = (q << scaleBits) + (s - q * freq) + start;
    }
    wb.first = w;
    putStream(x, lanes, wb, out);
}

// Adaptive binary probability of a 0 out of 2^12; shift-5 updates keep it within [31, 4065].
struct BitModel {
    std::uint32_t p0 = kBinaryScale / 2;
};

// Read side of the word stream. Decoding is branch-free: data-dependent decisions are turned into masks and
// arithmetic instead of jumps, because they are close to random and mispredicted jumps cost more than the
// arithmetic. The stream is read from a copy with zero padding (made by RansDecoder::padded()) at a clamped
// position, so reads never leave it. States are held by the callers, so hot loops keep them in locals.
struct WordReader {
    const std::uint8_t* data;
    std::size_t size;
    std::size_t pos = 0;

    /// The state after decoding slots [start, start + freq) out of 2^scaleBits, renormalised.
    std::uint32_t advance(std::uint32_t s, int scaleBits, std::uint32_t start, std::uint32_t freq) noexcept {
        s = freq * (s >> scaleBits) + (s & ((1u << scaleBits) - 1)) - start;
        const std::uint32_t renorm = s < kRansLow ? 1u : 0u;
        // The word at the read position, or zeros past the end (the position keeps counting, exact() notices).
        const std::uint8_t* q = data + std::min(pos, size);
        const std::uint32_t w = q[0] | (std::uint32_t(q[1]) << 8);
        pos += 2 * renorm;
        return select(renorm, (s << 16) | w, s);
    }
    /// c ? a : b without a jump. GCC turns the plain select into a jump here, which mispredicts on the
    /// renormalisation (close to random); on x86-64 a cmov is forced, elsewhere mask arithmetic is used.
    static std::uint32_t select(std::uint32_t c, std::uint32_t a, std::uint32_t b) noexcept {
#if defined(__x86_64__) && defined(__GNUC__)
        __asm__("testl %1, %1\n\tcmovnzl %2, %0" : "+r"(b) : "r"(c), "r"(a) : "cc");
        return b;
#else
        return b ^ ((a ^ b) & (0u - c));
#endif
    }
    /// Adaptive binary decision on state s.
    unsigned bit(std::uint32_t& s, BitModel& m) noexcept {
        const std::uint32_t p0 = m.p0;
        const std::uint32_t one = (s & (kBinaryScale - 1)) >= p0 ? 1u : 0u, mask = 0u - one;
        const std::uint32_t up = p0 + ((kBinaryScale - p0) >> 5), down = p0 - (p0 >> 5);
        // Masks instead of multiplications by `one` (shorter; signs are close to random, so no jumps).
        s = advance(s, kBinaryScaleBits, p0 & mask, p0 ^ ((p0 ^ (kBinaryScale - p0)) & mask));
        m.p0 = up ^ ((up ^ down) & mask);
        return one;
    }
};

// The decoder's states and stream.
class RansDecoder {
public:
    // 16 bytes: the SIMD decoder loads up to 7 words at a time from the clamped position.
    static std::vector<std::uint8_t> padded(std::span<const std::uint8_t> in) { return zeroPadded(in, 16); }
    /// `bytes` comes from padded(); `size` is the unpadded length.
    RansDecoder(const std::vector<std::uint8_t>& bytes, std::size_t size, int lanes) : in{bytes.data(), size} {
        const std::span<const std::uint8_t> span(in.data, in.size);
        std::fill(x, x + kMaxLanes, kRansLow);
        for (int lane = 0; lane < lanes; ++lane) {
            std::uint64_t v = 0;
            if (!getVarint(span, in.pos, v) || v > 0xFFFFFFFFu - kRansLow) {
                bad_ = true; // decoding goes on harmlessly (any state is safe); exact() reports it
                v = 0;
            }
            x[lane] = static_cast<std::uint32_t>(v) + kRansLow;
        }
    }
    /// An intact stream ends exactly at its last word with every state back at the encoder's start.
    bool exact() const noexcept {
        return !bad_ && in.pos == in.size &&
               std::all_of(x, x + kMaxLanes, [](std::uint32_t s) { return s == kRansLow; });
    }
    WordReader in;
    std::uint32_t x[kMaxLanes];

private:
    bool bad_ = false;
};

// ------------------------------------------------------------------------------ dense model

// Magnitude symbol: 0 and 1 stand for themselves; a magnitude of bit length n >= 2 is 2(n-1) + its top
// mantissa bit, and its n-2 lower bits go raw. Magnitudes below 2^30 give symbols below 60.
constexpr int kSymbols = 60;
constexpr int kMaxBitLength = 30;
// Activity contexts: half-octave classes of 4(N+U) + (NW+NE+UW+UE+UN) + 2 parent + 4 W (magnitudes of the
// neighbours in the previous row and slice, of the parent one level coarser, and the smallest magnitude of
// the previous coefficient's symbol). W makes each row a serial chain in the decoder (worth about 1 % on
// ch2better); the chains of the section's subbands are decoded interleaved so that they overlap.
constexpr int kActivityContexts = 25;
constexpr int kSignContexts = 27 * 8; // signs of W, N, U (negative, zero, positive) per orientation
constexpr int kTableBitsPerEntry = 6;

// Without jumps (the encoder's symbol loop mispredicted on them): k = floor(log2 max(u, 1)) and
// sh = max(k - 1, 0); u >> sh is the top two bits of u (u >= 2), or u itself (u < 2).
inline int symbolOf(std::uint32_t u) {
    const int k = 31 - std::countl_zero(u | 1u);
    const int sh = k - (k != 0 ? 1 : 0);
    return 2 * sh + static_cast<int>(u >> sh);
}
// Per symbol: how many raw mantissa bits follow it, its magnitude with those bits zero (base), and 4 base,
// the previous coefficient's share of the activity (its smallest magnitude stands in for it, because its
// raw bits are read in a later pass). Tables instead of arithmetic: shorter chains, no branches.
struct SymbolInfo {
    std::array<std::uint8_t, 64> rawBits{};
    alignas(64) std::array<std::uint32_t, 64> base{}; // aligned for the SIMD decoder's permutations
    std::array<std::uint32_t, 64> west{};
};
constexpr SymbolInfo kSymbolInfo = [] {
    SymbolInfo t;
    for (unsigned sym = 0; sym < kSymbols; ++sym) {
        const unsigned n = sym < 2 ? 0 : sym / 2 - 1;
        t.rawBits[sym] = static_cast<std::uint8_t>(n);
        t.base[sym] = sym < 2 ? sym : (2u | (sym & 1u)) << n;
        t.west[sym] = 4 * t.base[sym];
    }
    return t;
}();
// 0 for a = 0, 1 for a = 1, then two classes per octave (the bit below the leading one), capped at 24,
// which every a >= 2^11.5 reaches: a 4 KB table indexed by min(a, 4095) (three instructions).
constexpr std::array<std::uint8_t, 4096> kActivityClass = [] {
    std::array<std::uint8_t, 4096> t{};
    for (std::uint32_t a = 1; a < 4096; ++a) {
        int n = 0;
        while ((a >> n) > 1)
            ++n; // a has bit length n + 1
        const int half = n > 0 ? static_cast<int>((a >> (n - 1)) & 1u) : 0;
        t[a] = static_cast<std::uint8_t>(std::min(2 * n + 1 + half, kActivityContexts - 1));
    }
    return t;
}();
inline int activityContext(std::uint32_t a) {
    return kActivityClass[std::min<std::uint32_t>(a, 4095)];
}
inline unsigned signClass(std::int32_t v) {
    return static_cast<unsigned>(v > 0) + 2 * static_cast<unsigned>(v < 0);
}

// Frequencies (sum kTableScale, every present symbol >= 1) rebuilt from the quantised log weights that the
// section stores; encoder and decoder run this same code, so they agree bit for bit.
struct SymbolTable {
    std::array<std::uint16_t, kSymbols> start{}, freq{};
};

// The decoder's view of one table: slot-to-symbol lookup and the symbols' slot ranges, contiguous.
struct DecoderTable {
    std::uint16_t start[64] = {}, freq[64] = {};
    std::uint8_t lookup[kTableScale];
};

// q = 0: absent; else weight 2^((q - 1) / 4) (times 1024, integers so that every platform agrees), q < 64.
inline std::uint64_t weightOf(int q) {
    static constexpr std::array<std::uint64_t, 4> kQuarterOctave = {1024, 1218, 1448, 1722};
    return kQuarterOctave[static_cast<std::size_t>((q - 1) % 4)] << ((q - 1) / 4);
}

bool buildTable(const std::array<std::uint8_t, kSymbols>& q, int nsym, SymbolTable& t) {
    std::uint64_t total = 0;
    for (int s = 0; s < nsym; ++s)
        if (q[static_cast<std::size_t>(s)]) total += weightOf(q[static_cast<std::size_t>(s)]);
    if (total == 0) return false;
    std::array<std::uint32_t, kSymbols> f{};
    std::uint32_t sum = 0;
    for (int s = 0; s < nsym; ++s) {
        const auto i = static_cast<std::size_t>(s);
        if (!q[i]) continue;
        f[i] = static_cast<std::uint32_t>(std::max<std::uint64_t>(1, weightOf(q[i]) * kTableScale / total));
        sum += f[i];
    }
    // Rounding leaves the sum a little off: the largest entries absorb the difference.
    while (sum != kTableScale) {
        const auto big = static_cast<std::size_t>(std::max_element(f.begin(), f.begin() + nsym) - f.begin());
        if (sum < kTableScale) {
            f[big] += kTableScale - sum;
            sum = kTableScale;
        } else {
            const std::uint32_t take = std::min(sum - kTableScale, f[big] - 1);
            f[big] -= take;
            sum -= take;
        }
    }
    std::uint32_t c = 0;
    for (std::size_t i = 0; i < kSymbols; ++i) {
        t.start[i] = static_cast<std::uint16_t>(c);
        t.freq[i] = static_cast<std::uint16_t>(f[i]);
        c += f[i];
    }
    return true;
}

// Quantised log weight of a count: 1 + round(4 log2(count / total * 2^14)), clamped to 1..63.
inline std::uint8_t quantiseCount(std::uint64_t count, std::uint64_t total) {
    if (count == 0) return 0;
    const double l = std::log2(double(count) / double(total)) + 14.0;
    return static_cast<std::uint8_t>(std::clamp<long>(1 + std::lround(4.0 * l), 1, 63));
}

// Adaptive state shared by encoder and decoder.
struct DenseModel {
    std::array<BitModel, 4 * 8> rows; // row "all zero" flag: (previous y row zero, previous z row zero) x orientation
    std::array<BitModel, kSignContexts> signs;
};

// x in a RowJob::nonZero entry (x < 2^24; signBase, below 256, may sit above it).
constexpr std::uint32_t kListX = 0xFFFFFF;

// One non-zero row of one subband, handed by the walker to a side with its contexts precomputed.
struct RowJob {
    unsigned lane;                 // the subband's index in its section, which is also its rANS state
    std::size_t nx;
    const std::uint32_t* activity; // per x: neighbour and parent part of the magnitude context
    const std::uint16_t* signBase; // per x: neighbour part of the sign context
    std::int32_t* row;             // the row in the brick
    std::uint32_t* mag;            // its magnitudes in the zero-padded slice copy (mag[-1] and mag[nx] are 0)
    std::uint8_t* sgn;             // its sign classes (signClass) likewise
    std::uint8_t* syms;            // magnitude symbol per x (syms[-1] is 0: the previous symbol of x = 0)
    std::uint32_t* nonZero;        // scratch: x of the non-zero coefficients in order, `count` of them (the
                                   // SIMD decoder keeps signBase[x] in bits 24-31: read x as & kListX)
    std::uint32_t* withRawBits;    // SIMD decoder's scratch: the entries of nonZero with raw bits, `rawCount`
    std::size_t count;
    std::size_t rawCount;
};

// Where the encoder puts row `row`'s pending symbol events among the `rows` rows of a group, in the
// decoder's order (interleaveSymbols): x < minNx at events[x * rows + row], the other x at events[tail + x]
// (after the interleaved part and the ends of the rows before it).
struct SymbolSlots {
    RansEvent* events;
    std::size_t rows, row, minNx, tail;
};

// Walks section s row by row: at each (slice, row) position it takes that row of every subband of the
// section (they are independent given the previous section), codes their "all zero" flags, computes each
// non-zero row's magnitude and sign contexts from the previous row, the previous slice and the parent (no
// dependence on the row itself, so these loops have no serial chain), then hands the non-zero rows to
// side.rows, which interleaves them. Neighbours come from zero-padded copies of the current and the
// previous slice of each subband, so no loop has boundary tests.
struct SectionWalker {
    Dims brick;
    const std::vector<std::vector<SubbandBox>>& layout;
    std::size_t s;

    struct Band {
        const SubbandBox* box = nullptr;
        const SubbandBox* parent = nullptr;
        std::size_t nx = 0, ny = 0, nz = 0, pitch = 0;
        // Slice buffers of magnitudes and sign classes: row 0 is the zero row above y0; row r+1 holds row
        // y0+r; columns 0 and nx+1 are zero. Magnitudes are kept apart so that the context loops are plain
        // sums that vectorise.
        std::vector<std::uint32_t> cur, prev;
        std::vector<std::uint8_t> curSign, prevSign;
        std::size_t parentY = SIZE_MAX, parentZ = SIZE_MAX; // the parent row held in parentRow
        std::vector<std::uint8_t> rowZero, prevRowZero;
        std::vector<std::uint32_t> parentRow, activity, nonZero, withRawBits;
        std::vector<std::uint16_t> signBase;
        std::vector<std::uint8_t> syms;
    };

    template <class Side> void run(std::int32_t* c, Side& side) {
        const std::size_t sx = brick.x, sxy = brick.x * brick.y;
        const std::size_t nb = layout[s].size();
        std::array<Band, kMaxLanes> bands;
        std::size_t maxNy = 0, maxNz = 0;
        for (std::size_t k = 0; k < nb; ++k) {
            Band& b = bands[k];
            b.box = &layout[s][k];
            if (b.box->level > 0 && s >= 2)
                for (const SubbandBox& pb : layout[s - 1])
                    if (pb.orient == b.box->orient) b.parent = &pb;
            b.nx = b.box->x1 - b.box->x0;
            b.ny = b.box->y1 - b.box->y0;
            b.nz = b.box->z1 - b.box->z0;
            b.pitch = b.nx + 2;
            b.cur.assign((b.ny + 1) * b.pitch, 0);
            b.prev.assign((b.ny + 1) * b.pitch, 0);
            // 4 bytes more: the SIMD sign pass stores 4 bytes per sign (zeros after it, see signsSimd).
            b.curSign.assign((b.ny + 1) * b.pitch + 4, 0);
            b.prevSign.assign((b.ny + 1) * b.pitch + 4, 0);
            b.rowZero.assign(b.ny, 1);
            b.prevRowZero.assign(b.ny, 1);
            b.parentRow.assign(b.nx, 0);
            b.activity.assign(b.nx, 0);
            b.nonZero.assign(b.nx + 16, 0); // the SIMD decoder stores 16 entries at a time
            b.withRawBits.assign(b.nx + 16, 0);
            b.signBase.assign(b.nx, 0);
            b.syms.assign(b.nx + 4, 0); // syms[0] stays 0: the symbol before x = 0; 3 bytes for 4-byte stores
            maxNy = std::max(maxNy, b.ny);
            maxNz = std::max(maxNz, b.nz);
        }
        for (std::size_t zi = 0; zi < maxNz; ++zi) {
            for (std::size_t r = 0; r < maxNy; ++r) {
                std::array<RowJob, kMaxLanes> jobs;
                std::size_t nj = 0;
                for (std::size_t k = 0; k < nb; ++k) {
                    Band& b = bands[k];
                    if (zi >= b.nz || r >= b.ny) continue;
                    const SubbandBox& box = *b.box;
                    const std::size_t nx = b.nx, pitch = b.pitch, z = box.z0 + zi;
                    std::int32_t* row = c + z * sxy + (box.y0 + r) * sx + box.x0;
                    std::uint32_t* m = b.cur.data() + (r + 1) * pitch + 1;
                    std::uint8_t* sg = b.curSign.data() + (r + 1) * pitch + 1;
                    const auto orient = static_cast<unsigned>(box.orient);
                    const unsigned rctx = orient * 4 + (r > 0 ? b.rowZero[r - 1] : 1u) + 2u * b.prevRowZero[r];
                    const bool zero = side.rowFlag(static_cast<unsigned>(k), rctx, row, nx);
                    b.rowZero[r] = zero;
                    if (zero) {
                        std::fill(m, m + nx, 0);
                        std::fill(sg, sg + nx, 0);
                        continue;
                    }
                    std::uint32_t* parentRow = b.parentRow.data();
                    if (b.parent) {
                        // Rows 2k and 2k+1 share their parent row.
                        const SubbandBox& p = *b.parent;
                        const std::size_t pz = std::min(p.z0 + zi / 2, p.z1 - 1);
                        const std::size_t py = std::min(p.y0 + r / 2, p.y1 - 1);
                        if (pz != b.parentZ || py != b.parentY) {
                            // Child x has parent x / 2, clamped to the parent's last column.
                            const std::int32_t* prow = c + pz * sxy + py * sx + p.x0;
                            const std::size_t pairs = std::min(nx / 2, p.x1 - p.x0);
                            for (std::size_t px = 0; px < pairs; ++px)
                                parentRow[2 * px] = parentRow[2 * px + 1] = 2 * magnitude(prow[px]);
                            for (std::size_t x = 2 * pairs; x < nx; ++x)
                                parentRow[x] = 2 * magnitude(prow[std::min(x / 2, p.x1 - p.x0 - 1)]);
                            b.parentZ = pz;
                            b.parentY = py;
                        }
                    }
                    const std::uint32_t* n = m - pitch;
                    const std::uint32_t* u = b.prev.data() + (r + 1) * pitch + 1;
                    const std::uint32_t* un = u - pitch;
                    std::uint32_t* activity = b.activity.data();
                    for (std::size_t x = 0; x < nx; ++x)
                        activity[x] = 4 * (n[x] + u[x]) + n[x - 1] + n[x + 1] + u[x - 1] + u[x + 1] + un[x] + parentRow[x];
                    const std::uint8_t* ns = sg - pitch;
                    const std::uint8_t* us = b.prevSign.data() + (r + 1) * pitch + 1;
                    const auto sctx0 = static_cast<std::uint16_t>(orient * 27);
                    std::uint16_t* signBase = b.signBase.data();
                    for (std::size_t x = 0; x < nx; ++x)
                        signBase[x] = static_cast<std::uint16_t>(sctx0 + 3 * ns[x] + 9 * us[x]);
                    jobs[nj++] = {static_cast<unsigned>(k),
                                  nx,
                                  activity,
                                  signBase,
                                  row,
                                  m,
                                  sg,
                                  b.syms.data() + 1,
                                  b.nonZero.data(),
                                  b.withRawBits.data(),
                                  0,
                                  0};
                }
                if (nj > 0) side.rows(jobs.data(), nj);
            }
            for (std::size_t k = 0; k < nb; ++k)
                if (zi < bands[k].nz) {
                    std::swap(bands[k].cur, bands[k].prev);
                    std::swap(bands[k].curSign, bands[k].prevSign);
                    std::swap(bands[k].rowZero, bands[k].prevRowZero);
                }
        }
    }
};

// The order in which the scalar decoder visits the coefficients of a row group, which is the stream's
// decision order (the SIMD decoder steps through it column by column, and the encoder writes its events
// straight into it): magnitude symbols interleaved across the rows (x outer, row inner) up to
// the shortest row, then the rest of each row; then signs of the non-zero coefficients interleaved the
// same way (their n-th non-zero coefficient each); then each row's raw mantissa bits in turn.
template <class Step> void interleaveSymbols(const RowJob* jobs, std::size_t nj, Step&& step) {
    std::size_t minNx = jobs[0].nx;
    for (std::size_t i = 1; i < nj; ++i)
        minNx = std::min(minNx, jobs[i].nx);
    for (std::size_t x = 0; x < minNx; ++x)
        for (std::size_t i = 0; i < nj; ++i)
            step(i, x);
    for (std::size_t i = 0; i < nj; ++i)
        for (std::size_t x = minNx; x < jobs[i].nx; ++x)
            step(i, x);
}
/// step(i, n) for the n-th non-zero coefficient of row i.
template <class Step> void interleaveSigns(const RowJob* jobs, std::size_t nj, Step&& step) {
    std::size_t maxCount = 0;
    for (std::size_t i = 0; i < nj; ++i)
        maxCount = std::max(maxCount, jobs[i].count);
    for (std::size_t n = 0; n < maxCount; ++n)
        for (std::size_t i = 0; i < nj; ++i)
            if (n < jobs[i].count) step(i, n);
}

// ------------------------------------------------------------------------------ SIMD symbol pass

// The decoder's per-slot view of all tables of a section for the SIMD pass: per table 2048 entries of
// (slot - start) | freq << 11 | symbol << 23 (one gather gives the symbol and the rANS step), blocks of
// 2048 one after the other (block 0 decodes symbol 0 at no cost, for contexts without a table), and per
// activity class the offset of its block in entries (32 entries: the permutation reads two registers).
struct PackedTables {
    std::vector<std::uint32_t> entries;
    alignas(64) std::uint32_t offset[32] = {};
};

constexpr std::uint32_t packedEntry(std::uint32_t bias, std::uint32_t freq, std::uint32_t sym) {
    return bias | freq << 11 | sym << 23;
}

// The SIMD decoder's instruction sets; the SIMD encoder also needs IFMA (its division).
bool cpuHasDenseSimd() noexcept {
#ifdef VOLCL_DENSE_SIMD
    static const bool ok = [] {
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
               __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
               __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512vbmi2") &&
               __builtin_cpu_supports("bmi2") && __builtin_cpu_supports("popcnt");
    }();
    return ok;
#else
    return false;
#endif
}
bool cpuHasDenseEncoderSimd() noexcept {
#ifdef VOLCL_DENSE_SIMD
    static const bool ok = cpuHasDenseSimd() && __builtin_cpu_supports("avx512ifma");
    return ok;
#else
    return false;
#endif
}

std::atomic<bool> gForceScalar{[] {
    const char* e = std::getenv("VOLCL_DENSE_SCALAR");
    return e != nullptr && *e != '\0' && *e != '0';
}()};
// The encoder's switch, apart so that tests can pair either encoder with either decoder.
std::atomic<bool> gForceScalarEncoder{gForceScalar.load()};

#ifdef VOLCL_DENSE_SIMD
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
void symbolsSimd(const RowJob* jobs, std::size_t nj, std::size_t steps, __mmask8 lastMask, WordReader& in,
                 std::uint32_t* st, const PackedTables& pt) {
    const __mmask8 full = static_cast<__mmask8>((1u << nj) - 1u);
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
#endif

#ifdef VOLCL_DENSE_SIMD
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#pragma GCC diagnostic ignored "-Wuninitialized"
// The encoder's SIMD functions need IFMA besides the decoder's set (cpuHasDenseEncoderSimd checks for it).
#define VOLCL_SIMD_ENCODER_TARGET                                                                            \
    __attribute__((target("avx512f,avx512bw,avx512cd,avx512dq,avx512vl,avx512vbmi2,avx512ifma,bmi,bmi2,"    \
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
        const __mmask16 bound = _mm512_mask_cmple_epu32_mask(valid, lane, _mm512_alignr_epi32(lane, prev, 15));
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
                                                         _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11,
                                                                           12, 13, 14, 15))));
        for (std::uint32_t k = 0; k < 16; ++k)
            if (p + k < kSymbols && west[k] != kSymbolInfo.west[p + k]) return false;
    }
    return true;
}

// encodeRow 16 coefficients at a time (same outputs): the symbol and the previous one (a shifted vector),
// W and the activity class by arithmetic (lzcnt) where encodeRow reads tables, the per non-zero outputs
// by compressing stores.
VOLCL_SIMD_ENCODER_TARGET
std::size_t encodeRowSimd(const RowJob& j, const SymbolSlots& slots, std::uint32_t* signs, std::uint32_t* raws,
                          std::size_t& rawCount, std::uint32_t& all) {
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
        _mm512_mask_i32scatter_epi32(slots.events, valid, slot,
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
        const __m256i e = _mm256_or_si256(_mm256_or_si256(_mm256_maskz_mov_epi32(neg, p0),
                                                          _mm256_slli_epi32(freq, kEventFreqShift)),
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
        const __m512i binary = _mm512_cvtepu32_epi64(_mm256_and_si256(_mm256_srli_epi32(e, kEventBinaryShift), one32));
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
        const __m128i words = _mm_maskz_expand_epi16(static_cast<__mmask8>(0xFF00u >> n),
                                                      _mm_maskz_compress_epi16(flush, _mm512_cvtepi64_epi16(x)));
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
#endif

// Encoder pass 1: adaptive decisions become events at once; magnitude symbols are recorded as pending
// events (scaleBits 0, start = context * 64 + symbol) and resolved once the tables exist.
struct EncodeSide {
    DenseModel model;
    EncoderScratch& scratch = encoderScratch();
    // Room for the worst case (a row flag per row, a symbol and a sign per coefficient), filled at next.
    RansEvent* next = nullptr;
    // Symbol counts per context * 64 + symbol, in two halves (see rows()), summed by encodeDense().
    std::array<std::array<std::uint32_t, kActivityContexts * 64>, 2> counts{};
    RawWriter raw{scratch.raw};
    std::uintptr_t previousRow[kMaxLanes] = {}; // per lane, the row of its last row flag
    bool simd = false; // encodeRowSimd instead of encodeRow

    /// The event of an adaptive binary decision; updates the model.
    /// Masks instead of selects (signs are close to random, and GCC makes jumps of the selects).
    static RansEvent binaryEvent(BitModel& m, unsigned bit, unsigned lane) {
        const std::uint32_t p0 = m.p0, one = 0u - static_cast<std::uint32_t>(bit);
        const std::uint32_t up = p0 + ((kBinaryScale - p0) >> 5), down = p0 - (p0 >> 5);
        m.p0 = up ^ ((up ^ down) & one);
        return ransEvent(p0 & one, p0 ^ ((p0 ^ (kBinaryScale - p0)) & one), true, lane);
    }
    void binary(unsigned lane, BitModel& m, unsigned bit) {
        *next++ = binaryEvent(m, bit, lane);
    }
    bool rowFlag(unsigned lane, unsigned rctx, const std::int32_t* row, std::size_t nx) {
        // The lane's next row is likely as far on as this one from its previous row: fetch it now (the
        // walker visits up to 7 subbands' rows in turn, a pattern the hardware prefetchers miss).
        const auto at = reinterpret_cast<std::uintptr_t>(row);
        const std::uintptr_t ahead = at + (at - previousRow[lane]);
        previousRow[lane] = at;
        for (std::uintptr_t line = 0; line < 4 * nx; line += 64)
            __builtin_prefetch(reinterpret_cast<const void*>(ahead + line));
        bool zero = true;
#ifdef VOLCL_DENSE_SIMD
        if (simd)
            zero = rowIsZeroSimd(row, nx);
        else
#endif
            for (std::size_t x = 0; x < nx && zero; ++x)
                zero = row[x] == 0;
        binary(lane, model.rows[rctx], zero ? 1u : 0u);
        return zero;
    }
    /// One row's pass: per x the pending symbol event, straight into its place in the group's events (see
    /// SymbolSlots), the symbol, magnitude and sign class (j.syms, j.mag, j.sgn: the walker's context); per
    /// non-zero coefficient its sign context | negative << 16 (signs); per coefficient with raw mantissa
    /// bits (symbol >= 4) those bits with a 1 above them (raws, `rawCount` of them). Returns the non-zero
    /// count; `all` collects the magnitudes' bits. The encoder knows
    /// the previous symbol, so nothing chains from one x to the next. The reference for encodeRowSimd.
    static std::size_t encodeRow(const RowJob& j, const SymbolSlots& slots, std::uint32_t* signs,
                                 std::uint32_t* raws, std::size_t& rawCount, std::uint32_t& all) {
        const std::int32_t* row = j.row;
        const std::uint32_t* activity = j.activity;
        const std::uint16_t* signBase = j.signBase;
        std::uint32_t* mag = j.mag;
        std::uint8_t* sgn = j.sgn;
        std::uint8_t* syms = j.syms;
        unsigned prevSym = 0, prevSign = 0;
        std::size_t count = 0, rawN = 0;
        std::uint32_t any = 0;
        for (std::size_t x = 0; x < j.nx; ++x) {
            const std::int32_t v = row[x];
            const std::uint32_t u = magnitude(v);
            any |= u;
            const auto sym = static_cast<unsigned>(symbolOf(u));
            const auto ctx = static_cast<unsigned>(activityContext(activity[x] + kSymbolInfo.west[prevSym]));
            prevSym = sym;
            slots.events[x < slots.minNx ? x * slots.rows + slots.row : slots.tail + x] =
                pendingEvent(ctx * 64 + sym, j.lane);
            syms[x] = static_cast<std::uint8_t>(sym);
            mag[x] = u;
            const unsigned sign = signClass(v);
            sgn[x] = static_cast<std::uint8_t>(sign);
            signs[count] = (signBase[x] + prevSign) | static_cast<std::uint32_t>(v < 0) << 16;
            prevSign = sign;
            // Symbols above 59 (magnitudes out of range) are refused before anything uses these.
            const unsigned rawBits = kSymbolInfo.rawBits[sym & 63]; // 0 for symbols below 4
            raws[rawN] = (u & ((1u << rawBits) - 1u)) | 1u << rawBits;
            rawN += rawBits != 0;
            count += v != 0;
        }
        all |= any;
        rawCount = rawN;
        return count;
    }
    void rows(RowJob* jobs, std::size_t nj) {
        // Per row: the row pass (encodeRow or its SIMD twin) and the symbol counts; then the symbol events in
        // the decoder's interleaved order.
        std::size_t maxNx = 0;
        for (std::size_t i = 0; i < nj; ++i)
            maxNx = std::max(maxNx, jobs[i].nx);
        // Per row of the group, from the row pass: per non-zero coefficient the sign context | negative << 16,
        // per coefficient with raw bits those bits with a 1 above them.
        std::uint32_t* const signCodes = EncoderScratch::atLeast(scratch.signCodes, nj * maxNx);
        std::uint32_t* const rawCodes = EncoderScratch::atLeast(scratch.rawCodes, nj * maxNx);
        std::size_t minNx = maxNx;
        for (std::size_t i = 0; i < nj; ++i)
            minNx = std::min(minNx, jobs[i].nx);
        std::uint32_t all = 0;
        std::size_t tail = minNx * nj; // where the part of the row past minNx goes
        std::size_t rawCount[kMaxLanes];
        for (std::size_t i = 0; i < nj; ++i) {
            RowJob& j = jobs[i];
            const SymbolSlots slots{next, nj, i, minNx, tail - minNx};
            tail += j.nx - minNx;
#ifdef VOLCL_DENSE_SIMD
            if (simd)
                j.count = encodeRowSimd(j, slots, signCodes + i * maxNx, rawCodes + i * maxNx, rawCount[i], all);
            else
#endif
                j.count = encodeRow(j, slots, signCodes + i * maxNx, rawCodes + i * maxNx, rawCount[i], all);
        }
        // Before the counts are indexed with the symbols.
        if (all >> kMaxBitLength) throw Error("internal: wavelet coefficient magnitude out of range");
        // Two histograms taken in turn: runs of one code (mostly zeros) would otherwise chain every
        // increment to the previous one through memory.
        std::size_t k = 0;
        for (; k + 1 < tail; k += 2) {
            ++counts[0][next[k] & kEventFieldMask];
            ++counts[1][next[k + 1] & kEventFieldMask];
        }
        if (k < tail) ++counts[0][next[k] & kEventFieldMask];
        next += tail;
        // Sign events straight in the decoder's interleaved order (the n-th non-zero coefficient of each row
        // in turn), without jumps: steps past a row's count code a dummy model and leave no event (the
        // store lands where the next event goes). Rows of a group use disjoint sign models, so their model
        // chains are independent and overlap.
        std::size_t maxCount = 0;
        std::size_t rowCount[kMaxLanes];
        unsigned rowLane[kMaxLanes];
        for (std::size_t i = 0; i < nj; ++i) {
            rowCount[i] = jobs[i].count;
            rowLane[i] = jobs[i].lane;
            maxCount = std::max(maxCount, jobs[i].count);
        }
        BitModel dummy;
        RansEvent* ev = next;
#ifdef VOLCL_DENSE_SIMD
        if (simd)
            ev = signEventsSimd(rowCount, rowLane, nj, maxCount, signCodes, maxNx, model.signs.data(), ev);
        else
#endif
        for (std::size_t n = 0; n < maxCount; ++n)
            for (std::size_t i = 0; i < nj; ++i) {
                const bool valid = n < rowCount[i];
                const std::uint32_t sc = signCodes[i * maxNx + n];
                BitModel& m = valid ? model.signs[sc & 0xFFFF] : dummy;
                *ev = binaryEvent(m, sc >> 16, rowLane[i]);
                ev += valid;
            }
        next = ev;
        for (std::size_t i = 0; i < nj; ++i)
            raw.put(rawCodes + i * maxNx, rawCount[i]);
    }
};

// Decoder: per row group, one branch-free pass decodes the magnitude symbols of every row interleaved (one
// serial chain per row through the previous symbol, overlapping each other), a second the signs of the
// non-zero ones, interleaved likewise, a third their raw mantissa bits.
struct DecodeSide {
    RansDecoder rans;
    RawReader raw;
    DenseModel model;
    std::array<const DecoderTable*, kActivityContexts> tables;
    const PackedTables* packed = nullptr; // set when the SIMD symbol pass runs

#ifdef VOLCL_DENSE_SIMD
    // The SIMD pass over the columns all rows have (and the last one when the rows differ by one column
    // only, as the subbands of a section do: then the scalar order "x outer, row inner" is unchanged), the
    // rest of each row scalar.
    template <class Step>
    void symbolsVector(const RowJob* jobs, std::size_t nj, WordReader& in, std::uint32_t* st, Step& step) {
        std::size_t minNx = jobs[0].nx, maxNx = jobs[0].nx;
        for (std::size_t i = 1; i < nj; ++i) {
            minNx = std::min(minNx, jobs[i].nx);
            maxNx = std::max(maxNx, jobs[i].nx);
        }
        const std::size_t steps = maxNx - minNx <= 1 ? maxNx : minNx;
        unsigned lastMask = 0;
        for (std::size_t i = 0; i < nj; ++i)
            lastMask |= (jobs[i].nx >= steps ? 1u : 0u) << i;
        symbolsSimd(jobs, nj, steps, static_cast<__mmask8>(lastMask), in, st, *packed);
        for (std::size_t i = 0; i < nj; ++i)
            for (std::size_t x = steps; x < jobs[i].nx; ++x)
                step(i, x);
    }

    // Also makes the rows' lists (listNonZero).
    void signsVector(RowJob* jobs, std::size_t nj, WordReader& in, std::uint32_t* st) {
        std::size_t maxCount = 0;
        std::uint32_t counts[kMaxLanes];
        for (std::size_t i = 0; i < nj; ++i) {
            listNonZero(jobs[i]);
            counts[i] = static_cast<std::uint32_t>(jobs[i].count);
            maxCount = std::max(maxCount, jobs[i].count);
        }
        if (maxCount == 0) return;
        signsSimd(jobs, nj, maxCount, counts, in, st, model.signs.data());
    }
#endif

    bool rowFlag(unsigned lane, unsigned rctx, std::int32_t* row, std::size_t nx) {
        const bool zero = rans.in.bit(rans.x[lane], model.rows[rctx]) != 0;
        if (zero) std::fill(row, row + nx, 0);
        return zero;
    }
    void rows(RowJob* jobs, std::size_t nj) {
        // Locals that no store through the rows' pointers can alias, so they stay in registers or at least
        // out of the dependency chains.
        WordReader in = rans.in;
        std::uint32_t st[kMaxLanes];
        for (std::size_t i = 0; i < nj; ++i)
            st[i] = rans.x[jobs[i].lane];
        const std::array<const DecoderTable*, kActivityContexts> tab = tables;
        const auto step = [&](std::size_t i, std::size_t x) {
            const RowJob& j = jobs[i];
            const DecoderTable& t =
                *tab[static_cast<std::size_t>(activityContext(j.activity[x] + kSymbolInfo.west[j.syms[x - 1]]))];
            const std::uint32_t s = st[i];
            const unsigned sym = t.lookup[s & (kTableScale - 1)];
            st[i] = in.advance(s, kTableScaleBits, t.start[sym], t.freq[sym]);
            j.syms[x] = static_cast<std::uint8_t>(sym);
        };
#ifdef VOLCL_DENSE_SIMD
        if (packed != nullptr)
            symbolsVector(jobs, nj, in, st, step);
        else
#endif
            interleaveSymbols(jobs, nj, step);
        const bool simd = packed != nullptr;
#ifdef VOLCL_DENSE_SIMD
        if (simd) {
            signsVector(jobs, nj, in, st);
        } else
#endif
        {
            for (std::size_t i = 0; i < nj; ++i) {
                RowJob& j = jobs[i];
                std::fill(j.mag, j.mag + j.nx, 0);
                std::fill(j.sgn, j.sgn + j.nx, 0);
                std::size_t count = 0;
                for (std::size_t x = 0; x < j.nx; ++x) {
                    j.nonZero[count] = static_cast<std::uint32_t>(x);
                    count += j.syms[x] != 0;
                }
                j.count = count;
                j.withRawBits = j.nonZero;
                j.rawCount = count;
            }
            interleaveSigns(jobs, nj, [&](std::size_t i, std::size_t n) {
                const RowJob& j = jobs[i];
                const std::size_t x = j.nonZero[n];
                const unsigned negative = in.bit(st[i], model.signs[j.signBase[x] + j.sgn[x - 1]]);
                j.sgn[x] = static_cast<std::uint8_t>(1 + negative);
            });
        }
        for (std::size_t i = 0; i < nj; ++i)
            rans.x[jobs[i].lane] = st[i];
        rans.in = in;
        RawReader b = raw;
        for (std::size_t i = 0; i < nj; ++i) {
            RowJob& j = jobs[i];
            for (std::size_t n = 0; n < j.rawCount; ++n) {
                const std::size_t x = j.withRawBits[n] & kListX;
                const unsigned sym = j.syms[x];
                j.mag[x] = kSymbolInfo.base[sym] | b.get(kSymbolInfo.rawBits[sym]);
            }
            for (std::size_t x = 0; x < j.nx; ++x) {
                const std::uint32_t negative = 0u - static_cast<std::uint32_t>(j.sgn[x] >> 1);
                j.row[x] = static_cast<std::int32_t>((j.mag[x] ^ negative) - negative);
            }
        }
        raw = b;
    }
};

// Section layout (dense): u8 mode (0: one table, 1: one table per activity class, 2: every coefficient is
// zero and nothing follows), the tables (bit packed: per table 6 bits nsym, then nsym 6-bit quantised log
// weights; nsym 0 = unused table), varint size of the rANS stream, the rANS stream (varints of the final
// states minus 2^16, one per subband of the section, then 16-bit words), the raw mantissa bits.
constexpr std::uint8_t kOneTable = 0, kContextTables = 1, kAllZero = 2;
void encodeDense(std::span<const std::int32_t> coeffs, Dims brick,
                 const std::vector<std::vector<SubbandBox>>& layout, std::size_t s,
                 std::vector<std::uint8_t>& out) {
    bool anyNonZero = false;
    for (const SubbandBox& b : layout[s])
        for (std::size_t z = b.z0; z < b.z1 && !anyNonZero; ++z)
            for (std::size_t y = b.y0; y < b.y1 && !anyNonZero; ++y) {
                const std::int32_t* row = coeffs.data() + (z * brick.y + y) * brick.x;
                anyNonZero = std::any_of(row + b.x0, row + b.x1, [](std::int32_t v) { return v != 0; });
            }
    if (!anyNonZero) {
        out.push_back(kAllZero);
        return;
    }
    EncodeSide side;
    side.simd = !denseEncoderIsScalar();
    std::size_t maxEvents = 0;
    for (const SubbandBox& b : layout[s])
        maxEvents += 2 * b.count() + (b.y1 - b.y0) * (b.z1 - b.z0);
    // 8 events more: the SIMD pass loads 8 events from a group's start.
    RansEvent* const firstEvent = EncoderScratch::atLeast(side.scratch.events, maxEvents + 8);
    side.next = firstEvent;
    SectionWalker walker{brick, layout, s};
    // The encoder side only reads the coefficient array.
    walker.run(const_cast<std::int32_t*>(coeffs.data()), side);
    const std::span<const std::uint8_t> rawBytes = side.raw.finish();

    // Cost estimate of both context modes from the counts (entropy plus table bits); keep the cheaper one.
    auto cost = [](const std::array<std::uint32_t, kSymbols>& cnt) {
        std::uint64_t total = 0;
        int nsym = 0;
        for (int i = 0; i < kSymbols; ++i)
            if (cnt[static_cast<std::size_t>(i)]) {
                total += cnt[static_cast<std::size_t>(i)];
                nsym = i + 1;
            }
        double bits = 6.0 + kTableBitsPerEntry * nsym;
        for (auto v : cnt)
            if (v) bits -= double(v) * std::log2(double(v) / double(total));
        return bits;
    };
    std::array<std::array<std::uint32_t, kSymbols>, kActivityContexts> contextCounts{};
    for (std::size_t c = 0; c < kActivityContexts; ++c)
        for (std::size_t i = 0; i < kSymbols; ++i)
            contextCounts[c][i] = side.counts[0][c * 64 + i] + side.counts[1][c * 64 + i];
    std::array<std::uint32_t, kSymbols> merged{};
    double split = 0;
    for (const auto& cnt : contextCounts) {
        split += cost(cnt);
        for (std::size_t i = 0; i < kSymbols; ++i)
            merged[i] += cnt[i];
    }
    const bool useContexts = split < cost(merged) + 6.0 * (kActivityContexts - 1);

    std::array<std::array<std::uint32_t, kSymbols>, kActivityContexts> counts{};
    if (useContexts)
        counts = contextCounts;
    else
        counts[0] = merged;
    std::array<SymbolTable, kActivityContexts> tables{};
    BitWriter tableBits;
    const int ntables = useContexts ? kActivityContexts : 1;
    for (int t = 0; t < ntables; ++t) {
        const auto& cnt = counts[static_cast<std::size_t>(t)];
        std::uint64_t total = 0;
        int nsym = 0;
        for (int i = 0; i < kSymbols; ++i)
            if (cnt[static_cast<std::size_t>(i)]) {
                total += cnt[static_cast<std::size_t>(i)];
                nsym = i + 1;
            }
        tableBits.put(static_cast<std::uint32_t>(nsym), 6);
        if (nsym == 0) continue;
        std::array<std::uint8_t, kSymbols> q{};
        for (int i = 0; i < nsym; ++i) {
            q[static_cast<std::size_t>(i)] = quantiseCount(cnt[static_cast<std::size_t>(i)], total);
            tableBits.put(q[static_cast<std::size_t>(i)], 6);
        }
        buildTable(q, nsym, tables[static_cast<std::size_t>(t)]);
    }
    tableBits.finish();

    // Slots of every pending code (context * 64 + symbol) in one flat table: the backward pass then resolves
    // an event with one load, no test of the mode and no division.
    std::array<RansEvent, kActivityContexts * 64> codeSlots{};
    for (std::size_t c = 0; c < kActivityContexts; ++c)
        for (std::size_t sym = 0; sym < kSymbols; ++sym) {
            const SymbolTable& t = tables[useContexts ? c : 0];
            codeSlots[c * 64 + sym] = ransEvent(t.start[sym], t.freq[sym], false, 0);
        }
    std::vector<std::uint8_t> stream;
    std::fill(side.next, side.next + 8, RansEvent(0)); // defined values in the SIMD pass's last loads
    const std::span<RansEvent> events(firstEvent, side.next);
    const int lanes = static_cast<int>(layout[s].size());
#ifdef VOLCL_DENSE_SIMD
    if (!denseEncoderIsScalar())
        ransEncodeSimd(events, lanes, codeSlots.data(), stream);
    else
#endif
        ransEncode(events, lanes, codeSlots.data(), stream);

    out.push_back(useContexts ? kContextTables : kOneTable);
    out.insert(out.end(), tableBits.bytes.begin(), tableBits.bytes.end());
    putVarint(out, stream.size());
    out.insert(out.end(), stream.begin(), stream.end());
    out.insert(out.end(), rawBytes.begin(), rawBytes.end());
}

void decodeDense(std::span<const std::uint8_t> in, std::span<std::int32_t> coeffs, Dims brick,
                 const std::vector<std::vector<SubbandBox>>& layout, std::size_t s, const char* what) {
    if (in.empty() || in[0] > kAllZero) corrupt(what, "invalid dense section header");
    if (in[0] == kAllZero) {
        if (in.size() != 1) corrupt(what, "unexpected bytes after an all-zero section");
        for (const SubbandBox& b : layout[s])
            for (std::size_t z = b.z0; z < b.z1; ++z)
                for (std::size_t y = b.y0; y < b.y1; ++y) {
                    std::int32_t* row = coeffs.data() + (z * brick.y + y) * brick.x;
                    std::fill(row + b.x0, row + b.x1, 0);
                }
        return;
    }
    const bool useContexts = in[0] == kContextTables;
    const int ntables = useContexts ? kActivityContexts : 1;
    // Tables a valid stream never selects decode everything as symbol 0 at no cost; a corrupted stream
    // that reaches them fails the final state check.
    // Contexts without a table point to one that decodes symbol 0 at no cost: a valid stream never uses
    // them, a corrupted one that does fails the final state check. Only sent tables are built (small
    // sections would otherwise pay for all 25).
    static const DecoderTable kUnused = [] {
        DecoderTable t;
        t.freq[0] = kTableScale;
        std::memset(t.lookup, 0, sizeof t.lookup);
        return t;
    }();
    std::vector<DecoderTable> tables;
    tables.reserve(static_cast<std::size_t>(ntables));
    std::array<const DecoderTable*, kActivityContexts> tablePtr;
    tablePtr.fill(&kUnused);
    // Table bits: a byte-aligned bit stream whose length follows from its content.
    BitReader tb(in.subspan(1));
    std::size_t tableBitCount = 0;
    for (int t = 0; t < ntables; ++t) {
        const int nsym = static_cast<int>(tb.get(6));
        tableBitCount += 6;
        if (nsym > kSymbols) corrupt(what, "invalid symbol table");
        if (nsym == 0) continue;
        std::array<std::uint8_t, kSymbols> q{};
        for (int i = 0; i < nsym; ++i)
            q[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(tb.get(6));
        tableBitCount += 6 * static_cast<std::size_t>(nsym);
        SymbolTable st;
        if (!buildTable(q, nsym, st)) corrupt(what, "empty symbol table");
        DecoderTable& d = tables.emplace_back();
        for (std::size_t sym = 0; sym < kSymbols; ++sym) {
            d.start[sym] = st.start[sym];
            d.freq[sym] = st.freq[sym];
            std::memset(d.lookup + st.start[sym], static_cast<int>(sym), st.freq[sym]);
        }
        if (useContexts)
            tablePtr[static_cast<std::size_t>(t)] = &d;
        else
            tablePtr.fill(&d);
    }
    const std::size_t tableBytes = (tableBitCount + 7) / 8;
    if (in.size() - 1 < tableBytes) corrupt(what, "truncated dense section");
    std::size_t head = 1 + tableBytes;
    std::uint64_t n = 0;
    if (!getVarint(in, head, n)) corrupt(what, "truncated dense section");
    if (n > in.size() - head) corrupt(what, "entropy section sizes exceed the brick");
    const std::vector<std::uint8_t> ransBytes = RansDecoder::padded(in.subspan(head, n));
    const std::vector<std::uint8_t> rawBytes = RawReader::padded(in.subspan(head + n));
    DecodeSide side{RansDecoder(ransBytes, n, static_cast<int>(layout[s].size())),
                    RawReader(rawBytes, in.size() - head - n),
                    {},
                    tablePtr,
                    nullptr};
    // Entries of the SIMD decoder's non-zero lists hold x in 24 bits.
    if (!denseDecoderIsScalar() && brick.x <= kListX) {
        // Reused across sections: 25 tables are 200 KB, which malloc would map and unmap every time.
        thread_local PackedTables pt;
        pt.entries.resize((tables.size() + 1) * kTableScale + 2);
        for (std::uint32_t slot = 0; slot < kTableScale; ++slot)
            pt.entries[slot] = packedEntry(slot, kTableScale, 0);
        std::fill(pt.offset, pt.offset + 32, 0u);
        for (std::size_t b = 0; b < tables.size(); ++b) {
            const DecoderTable& d = tables[b];
            std::uint32_t* e = pt.entries.data() + (b + 1) * kTableScale;
            for (std::uint32_t sym = 0; sym < kSymbols; ++sym)
                for (std::uint32_t k = 0; k < d.freq[sym]; ++k)
                    e[d.start[sym] + k] = packedEntry(k, d.freq[sym], sym);
        }
        for (std::size_t c = 0; c < kActivityContexts; ++c)
            if (tablePtr[c] != &kUnused)
                pt.offset[c] = static_cast<std::uint32_t>(tablePtr[c] - tables.data() + 1) * kTableScale;
        side.packed = &pt;
    }
    SectionWalker walker{brick, layout, s};
    walker.run(coeffs.data(), side);
    if (!side.rans.exact()) corrupt(what, "entropy stream does not end where its size says");
    if (!side.raw.exact()) corrupt(what, "raw bit stream length mismatch");
}

} // namespace

bool denseDecoderSimdAvailable() noexcept {
    return cpuHasDenseSimd();
}
void setDenseDecoderScalar(bool force) noexcept {
    gForceScalar.store(force, std::memory_order_relaxed);
}
bool denseDecoderIsScalar() noexcept {
    return !cpuHasDenseSimd() || gForceScalar.load(std::memory_order_relaxed);
}
bool denseEncoderArithmeticMatchesTables() {
#ifdef VOLCL_DENSE_SIMD
    if (cpuHasDenseEncoderSimd()) return arithmeticMatchesTables();
#endif
    return true;
}
void setDenseEncoderScalar(bool force) noexcept {
    gForceScalarEncoder.store(force, std::memory_order_relaxed);
}
bool denseEncoderIsScalar() noexcept {
    return !cpuHasDenseEncoderSimd() || gForceScalarEncoder.load(std::memory_order_relaxed);
}

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

// Calls fn(row, len, box) for each row of the section's subbands (x fastest, in coding order).
template <class T, class Fn>
void forEachSectionRow(T* c, const std::vector<SubbandBox>& sec, Dims brick, Fn fn) {
    for (const SubbandBox& b : sec)
        for (std::size_t z = b.z0; z < b.z1; ++z)
            for (std::size_t y = b.y0; y < b.y1; ++y)
                fn(c + (z * brick.y + y) * brick.x + b.x0, b.x1 - b.x0, b);
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

} // namespace

void encodeSection(std::span<const std::int32_t> coeffs, Dims brick,
                   const std::vector<std::vector<SubbandBox>>& layout, std::size_t s, EntropyMode mode,
                   std::vector<std::uint8_t>& out) {
    std::size_t count = 0;
    for (const SubbandBox& b : layout[s])
        count += b.count();
    if (count == 0) return;
    if (mode == EntropyMode::Dense) {
        encodeDense(coeffs, brick, layout, s, out);
    } else {
        encodeFast(coeffs, layout[s], brick, out);
    }
}

void decodeSection(std::span<const std::uint8_t> in, std::span<std::int32_t> coeffs, Dims brick,
                   const std::vector<std::vector<SubbandBox>>& layout, std::size_t s, EntropyMode mode,
                   const char* what) {
    std::size_t count = 0;
    for (const SubbandBox& b : layout[s])
        count += b.count();
    if (count == 0) {
        if (!in.empty()) corrupt(what, "unexpected data in an empty section");
        return;
    }
    if (mode == EntropyMode::Dense) {
        decodeDense(in, coeffs, brick, layout, s, what);
    } else {
        decodeFast(in, coeffs, layout[s], brick, what, nullptr);
    }
}

void decodeSections(std::span<const std::span<const std::uint8_t>> sections, std::span<std::int32_t> coeffs,
                    Dims brick, const std::vector<std::vector<SubbandBox>>& layout, EntropyMode mode,
                    const char* what, const Dequantiser* dq) {
    for (std::size_t s = 0; s < sections.size(); ++s) {
        if (mode == EntropyMode::Fast)
            decodeFast(sections[s], coeffs, layout[s], brick, what, dq); // checks empty sections itself
        else
            decodeSection(sections[s], coeffs, brick, layout, s, mode, what);
    }
    if (dq && mode == EntropyMode::Dense)
        for (std::size_t s = 0; s < sections.size(); ++s)
            forEachSectionRow(coeffs.data(), layout[s], brick,
                              [&](std::int32_t* row, std::size_t len, const SubbandBox& b) {
                                  dequantiseRow(row, reinterpret_cast<float*>(row), len, dq->step(b),
                                                dq->bias);
                              });
}

} // namespace volcl
