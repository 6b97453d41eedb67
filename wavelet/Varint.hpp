// LEB128 varints (7 bits a byte, low first), the one variable-length integer of the .vcz payloads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace volcl {

/// The longest varint: 10 bytes hold any 64-bit value.
inline constexpr std::size_t kMaxVarintBytes = 10;

/// Bytes putVarint writes for `v`.
inline std::size_t varintBytes(std::uint64_t v) noexcept {
    std::size_t n = 1;
    for (; v >= 0x80; v >>= 7)
        ++n;
    return n;
}

inline void putVarint(std::vector<std::uint8_t>& out, std::uint64_t v) {
    while (v >= 0x80) {
        out.push_back(static_cast<std::uint8_t>(v | 0x80));
        v >>= 7;
    }
    out.push_back(static_cast<std::uint8_t>(v));
}

/// Signed values as unsigned ones of about the same magnitude (0, -1, 1, -2, ... -> 0, 1, 2, 3, ...), so small
/// negative numbers stay small varints.
inline std::uint64_t zigzagEncode(std::int64_t v) noexcept {
    return (static_cast<std::uint64_t>(v) << 1) ^ static_cast<std::uint64_t>(v >> 63);
}
inline std::int64_t zigzagDecode(std::uint64_t u) noexcept {
    return static_cast<std::int64_t>(u >> 1) ^ -static_cast<std::int64_t>(u & 1);
}

enum class VarintStatus { Ok, Truncated, TooLong };

/// Reads a varint of at most `maxBytes` bytes (10 hold any 64-bit value) at `pos`, advancing it.
inline VarintStatus getVarint(std::span<const std::uint8_t> in, std::size_t& pos, std::uint64_t& v,
                              int maxBytes = 10) {
    v = 0;
    for (int i = 0; i < maxBytes; ++i) {
        if (pos >= in.size()) return VarintStatus::Truncated;
        const std::uint8_t b = in[pos++];
        v |= std::uint64_t(b & 0x7F) << (7 * i);
        if (!(b & 0x80)) return VarintStatus::Ok;
    }
    return VarintStatus::TooLong;
}

} // namespace volcl
