// The two sides of the mesh codec's entropy coding over the wavelet codec's rANS: adaptive binary decisions
// and raw bits. Both offer bit() and raw() with the same signature, so one template codes and decodes.
#pragma once

#include "wavelet/entropy/BitIo.hpp"
#include "wavelet/entropy/Rans.hpp"

#include <cstdint>
#include <span>
#include <vector>

namespace volcl::meshcodec {

using entropy::BitModel;
/// Raw fields go out in pieces of at most this many bits (RawWriter's limit).
inline constexpr int kRawPiece = 28;

/// Records decisions (one rANS lane) and raw bits; bit() and raw() return the value they are given.
class SymbolEncoder {
public:
    static constexpr bool kDecoding = false;
    unsigned bit(BitModel& m, unsigned b) {
        events_.push_back(entropy::binaryEvent(m, b, 0));
        return b;
    }
    std::uint64_t raw(int n, std::uint64_t v) {
        for (int s = 0; s < n; s += kRawPiece) {
            const int k = n - s < kRawPiece ? n - s : kRawPiece;
            codes_.push_back((1u << k) |
                             static_cast<std::uint32_t>((v >> s) & ((std::uint64_t(1) << k) - 1)));
        }
        return v;
    }
    /// The rANS stream and the raw bytes.
    void finish(std::vector<std::uint8_t>& rans, std::vector<std::uint8_t>& raw) const {
        rans.clear();
        entropy::ransEncode(events_, 1, nullptr, rans);
        std::vector<std::uint8_t> buffer;
        entropy::RawWriter w(buffer);
        w.put(codes_.data(), codes_.size());
        const std::span<const std::uint8_t> bytes = w.finish();
        raw.assign(bytes.begin(), bytes.end());
    }

private:
    std::vector<entropy::RansEvent> events_;
    std::vector<std::uint32_t> codes_;
};

/// Reads what SymbolEncoder wrote; the values passed in are ignored. Reading past either stream's end
/// yields zeros (harmless) and makes exact() false.
class SymbolDecoder {
public:
    static constexpr bool kDecoding = true;
    SymbolDecoder(std::span<const std::uint8_t> rans, std::span<const std::uint8_t> raw)
        : ransBytes_(entropy::RansDecoder::padded(rans)), rans_(ransBytes_, rans.size(), 1),
          rawBytes_(entropy::RawReader::padded(raw)), raw_(rawBytes_, raw.size()) {}
    unsigned bit(BitModel& m, unsigned) { return rans_.in.bit(rans_.x[0], m); }
    std::uint64_t raw(int n, std::uint64_t) {
        std::uint64_t v = 0;
        for (int s = 0; s < n; s += kRawPiece) {
            const int k = n - s < kRawPiece ? n - s : kRawPiece;
            v |= std::uint64_t(raw_.get(static_cast<unsigned>(k))) << s;
        }
        return v;
    }
    /// Both streams consumed exactly, the rANS state back at its start.
    bool exact() const noexcept { return rans_.exact() && raw_.exact(); }

private:
    std::vector<std::uint8_t> ransBytes_;
    entropy::RansDecoder rans_;
    std::vector<std::uint8_t> rawBytes_;
    entropy::RawReader raw_;
};

} // namespace volcl::meshcodec
