// Plain bit streams of the entropy coders: table bits and raw mantissa bits (writers and branch-free
// readers).
#pragma once

#include "core/Error.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

namespace volcl::entropy {

/// Throws IoError "<what>: <why> (corrupted data)".
[[noreturn]] void corrupt(const char* what, const char* why);

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
inline std::vector<std::uint8_t> zeroPadded(std::span<const std::uint8_t> in, std::size_t pad) {
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

} // namespace volcl::entropy
