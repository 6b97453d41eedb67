// Interleaved rANS of the dense coder: up to 7 states sharing one stream of 16-bit words, coded events,
// the encoder's per-thread scratch and backward pass, the decoder's branch-free word reader.
#pragma once

#include "wavelet/Varint.hpp"
#include "wavelet/entropy/BitIo.hpp"

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace volcl::entropy {

// ------------------------------------------------------------------------------ rANS

// One state per subband of a section (up to 7) shares one stream of 16-bit words: the subbands of a section
// depend on each other only through the previous section, so the decoder works on the same row of every
// subband at once and their serial symbol chains overlap in the out-of-order core. States live in
// [2^16, 2^32).
inline constexpr std::uint32_t kRansLow = 1u << 16;
inline constexpr int kMaxLanes = 7;
inline constexpr int kBinaryScaleBits = 12; // adaptive binary decisions
inline constexpr std::uint32_t kBinaryScale = 1u << kBinaryScaleBits;
// Magnitude tables use 11 bits: the decoder's 25 slot-to-symbol tables (50 KB) then stay near L1.
inline constexpr int kTableScaleBits = 11;
inline constexpr std::uint32_t kTableScale = 1u << kTableScaleBits;

// One coded decision, packed in 4 bytes (the encoder keeps a section's events, up to ~2 MB with 6-byte
// ones, beside the 1 MB brick in L2): slots [start, start + freq) out of 2^scaleBits on state `lane`.
// Bits 0-11 start, 12-24 freq, bit 25 set for the 12-bit scale of binary decisions (else 11 bits, the
// tables'), bits 29-31 the lane. A pending magnitude symbol has freq 0 and its code (context * 64 +
// symbol, below 1600) in the start bits; the lane in the top bits lets the SIMD pass find groups of
// distinct lanes with one shift.
using RansEvent = std::uint32_t;
inline constexpr int kEventFreqShift = 12, kEventBinaryShift = 25, kEventLaneShift = 29;
inline constexpr RansEvent kEventFieldMask = 0xFFF, kEventFreqMask = 0x1FFF;
inline constexpr RansEvent ransEvent(std::uint32_t start, std::uint32_t freq, bool binary, unsigned lane) {
    return start | freq << kEventFreqShift | std::uint32_t(binary) << kEventBinaryShift |
           lane << kEventLaneShift;
}
inline constexpr RansEvent pendingEvent(std::uint32_t code, unsigned lane) {
    return code | lane << kEventLaneShift;
}

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
EncoderScratch& encoderScratch();
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
void putStream(const std::uint32_t* x, int lanes, const WordBuffer& wb, std::vector<std::uint8_t>& out);
// The scalar backward pass (the reference for the SIMD one): encodes events given in decoding order (the
// rANS encoder runs backwards, so they are collected first) and appends the stream to `out`. Pending
// events take their slots from `codeSlots` (per code, an event without lane).
void ransEncode(std::span<const RansEvent> events, int lanes, const RansEvent* codeSlots,
                std::vector<std::uint8_t>& out);

// Adaptive binary probability of a 0 out of 2^12; shift-5 updates keep it within [31, 4065].
struct BitModel {
    std::uint32_t p0 = kBinaryScale / 2;
};

/// The event of an adaptive binary decision; updates the model as WordReader::bit() does.
/// Masks instead of selects (signs are close to random, and GCC makes jumps of the selects).
inline RansEvent binaryEvent(BitModel& m, unsigned bit, unsigned lane) {
    const std::uint32_t p0 = m.p0, one = 0u - static_cast<std::uint32_t>(bit);
    const std::uint32_t up = p0 + ((kBinaryScale - p0) >> 5), down = p0 - (p0 >> 5);
    m.p0 = up ^ ((up ^ down) & one);
    return ransEvent(p0 & one, p0 ^ ((p0 ^ (kBinaryScale - p0)) & one), true, lane);
}

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
        // The word at the read position, or zeros past the end (the position keeps counting, exact()
        // notices).
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
    RansDecoder(const std::vector<std::uint8_t>& bytes, std::size_t size, int lanes)
        : in{bytes.data(), size} {
        const std::span<const std::uint8_t> span(in.data, in.size);
        std::fill(x, x + kMaxLanes, kRansLow);
        for (int lane = 0; lane < lanes; ++lane) {
            std::uint64_t v = 0;
            if (getVarint(span, in.pos, v, 5) != VarintStatus::Ok || v > 0xFFFFFFFFu - kRansLow) {
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

} // namespace volcl::entropy
