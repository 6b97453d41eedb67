// The rANS encoder's scalar backward pass, stream output and per-thread scratch.
#include "wavelet/entropy/Rans.hpp"

namespace volcl::entropy {

namespace {
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
} // namespace

EncoderScratch& encoderScratch() {
    thread_local EncoderScratch s;
    return s;
}

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

void ransEncode(std::span<const RansEvent> events, int lanes, const RansEvent* codeSlots,
                std::vector<std::uint8_t>& out) {
    WordBuffer wb(events.size());
    std::uint16_t* w = wb.first;
    std::uint32_t x[kMaxLanes];
    std::fill(x, x + kMaxLanes, kRansLow);
    for (std::size_t k = events.size(); k-- > 0;) {
        const RansEvent raw = events[k];
        const unsigned lane = raw >> kEventLaneShift;
        const RansEvent e =
            (raw >> kEventFreqShift & kEventFreqMask) == 0 ? codeSlots[raw & kEventFieldMask] : raw;
        const std::uint32_t start = e & kEventFieldMask, freq = e >> kEventFreqShift & kEventFreqMask;
        const int scaleBits = kTableScaleBits + static_cast<int>(e >> kEventBinaryShift & 1u);
        std::uint32_t s = x[lane];
        // At most one 16-bit word per event: states stay below 2^32 and freq >= 1.
        const bool flush = std::uint64_t(s) >= (std::uint64_t(freq) << (32 - scaleBits));
        w[-1] = static_cast<std::uint16_t>(s); // without a flush a later word overwrites it (one spare word)
        w -= flush;
        s >>= 16 * flush;
        const auto q =
            freq == 1 ? s : static_cast<std::uint32_t>((static_cast<Uint128>(s) * kReciprocal[freq]) >> 64);
        x[lane] = (q << scaleBits) + (s - q * freq) + start;
    }
    wb.first = w;
    putStream(x, lanes, wb, out);
}

} // namespace volcl::entropy
