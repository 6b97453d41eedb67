// Entropy coders for wavelet coefficient sections: dense (context-modelled interleaved rANS) and fast
// (libzstd over byte planes).
//
// Dense mode is a hand-written rANS coder (three interleaved 32-bit states sharing one stream of 16-bit
// words) because the ratio comes from the coefficient model and no Debian library takes caller-defined
// contexts: zstd, xz and brotli model bytes, libzstd's FSE/huff0 are not public API, and htscodecs' rANS
// (libhtscodecs-dev) has order-0/1 byte models only. The model mixes two kinds of decisions in one stream:
// magnitude symbols from static per-section tables (chosen by a context of neighbour and parent
// magnitudes, tables sent with the section) and adaptive binary decisions (row "all zero" flags and signs,
// whose contexts are too many for sent tables).
// Fast mode uses libzstd.
#include "wavelet/EntropyCoder.hpp"

#include "host/Error.hpp"

#include <zstd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <type_traits>

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

inline int bitLength(std::uint32_t v) {
    return 32 - std::countl_zero(v);
}
inline std::uint32_t magnitude(std::int32_t v) {
    return v < 0 ? 0u - static_cast<std::uint32_t>(v) : static_cast<std::uint32_t>(v);
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

// Branch-free reader for the raw mantissa bits (up to 28 per call): it reads from a copy of the stream
// with 8 zero bytes of padding (made by padded()), so every read is one unaligned 8-byte load; positions
// past the end are clamped to the padding and reported by exact(). Cheap to copy (no ownership).
class RawReader {
public:
    static std::vector<std::uint8_t> padded(std::span<const std::uint8_t> in) {
        std::vector<std::uint8_t> b(in.size() + 8, 0);
        std::copy(in.begin(), in.end(), b.begin());
        return b;
    }
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

// Three states share one stream of 16-bit words: magnitude symbols of even and odd x on lanes 0 and 1 (row
// flags on lane 0) so that two symbol chains overlap in the decoder, signs on lane 2. States live in
// [2^16, 2^32).
constexpr std::uint32_t kRansLow = 1u << 16;
constexpr int kLanes = 3;
constexpr unsigned kSignLane = 2;
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

// One coded decision: slots [start, start + freq) out of 2^scaleBits, on state `lane`.
struct RansEvent {
    std::uint16_t start, freq;
    std::uint8_t scaleBits, lane;
};

// Encodes events given in decoding order; the rANS encoder runs backwards, so they are collected first.
// Appends the stream to `out`.
void ransEncode(const std::vector<RansEvent>& ev, std::vector<std::uint8_t>& out) {
    std::vector<std::uint16_t> words;
    words.reserve(ev.size() / 2 + 8);
    std::uint32_t x[kLanes] = {kRansLow, kRansLow, kRansLow};
    for (std::size_t k = ev.size(); k-- > 0;) {
        const RansEvent& e = ev[k];
        std::uint32_t& s = x[e.lane];
        const std::uint32_t freq = e.freq;
        if (std::uint64_t(s) >= (std::uint64_t(freq) << (32 - e.scaleBits))) {
            words.push_back(static_cast<std::uint16_t>(s));
            s >>= 16;
        }
        s = ((s / freq) << e.scaleBits) + (s % freq) + e.start;
    }
    // Final states as varints of x - 2^16 (an unused lane costs one byte), then the words.
    for (std::uint32_t state : x)
        putVarint(out, state - kRansLow);
    const std::size_t base = out.size();
    out.resize(base + 2 * words.size());
    std::uint8_t* p = out.data() + base;
    for (std::size_t i = words.size(); i-- > 0; p += 2) {
        p[0] = static_cast<std::uint8_t>(words[i]);
        p[1] = static_cast<std::uint8_t>(words[i] >> 8);
    }
}

// Adaptive binary probability of a 0 out of 2^12; shift-5 updates keep it within [31, 4065].
struct BitModel {
    std::uint32_t p0 = kBinaryScale / 2;
};

// Branch-free decoder: data-dependent decisions are turned into masks and arithmetic instead of jumps,
// because they are close to random and mispredicted jumps cost more than the arithmetic. The stream is
// read from a copy with zero padding (made by padded()) at a clamped position, so reads never leave it.
class RansDecoder {
public:
    static std::vector<std::uint8_t> padded(std::span<const std::uint8_t> in) {
        std::vector<std::uint8_t> b(in.size() + 2, 0);
        std::copy(in.begin(), in.end(), b.begin());
        return b;
    }
    /// `bytes` comes from padded(); `size` is the unpadded length.
    RansDecoder(const std::vector<std::uint8_t>& bytes, std::size_t size) : data_(bytes.data()), size_(size) {
        const std::span<const std::uint8_t> in(data_, size_);
        for (std::uint32_t& s : x_) {
            std::uint64_t v = 0;
            if (!getVarint(in, pos_, v) || v > 0xFFFFFFFFu - kRansLow) {
                bad_ = true; // decoding goes on harmlessly (any state is safe); exact() reports it
                v = 0;
            }
            s = static_cast<std::uint32_t>(v) + kRansLow;
        }
    }
    std::uint32_t slot(unsigned lane, int scaleBits) const noexcept {
        return x_[lane] & ((1u << scaleBits) - 1);
    }
    void advance(unsigned lane, int scaleBits, std::uint32_t start, std::uint32_t freq) noexcept {
        std::uint32_t s = x_[lane];
        s = freq * (s >> scaleBits) + (s & ((1u << scaleBits) - 1)) - start;
        const std::uint32_t renorm = s < kRansLow ? 1u : 0u;
        const std::uint32_t w = word();
        x_[lane] = (s << (16 * renorm)) | (w & (0u - renorm));
        pos_ += 2 * renorm;
    }
    /// Adaptive binary decision; with active = 0 a no-op that returns 0 and leaves everything as is.
    unsigned bit(unsigned lane, BitModel& m, std::uint32_t active = 1) noexcept {
        const std::uint32_t p0 = m.p0;
        const std::uint32_t one = (slot(lane, kBinaryScaleBits) >= p0 ? 1u : 0u) & active;
        const std::uint32_t freqActive = p0 + one * (kBinaryScale - 2 * p0);
        const std::uint32_t freq = freqActive + (1u - active) * (kBinaryScale - freqActive);
        advance(lane, kBinaryScaleBits, one * p0, freq);
        const std::uint32_t up = p0 + ((kBinaryScale - p0) >> 5), down = p0 - (p0 >> 5);
        const std::uint32_t next = up + one * (down - up);
        m.p0 = p0 + ((0u - active) & (next - p0));
        return one;
    }
    /// An intact stream ends exactly at its last word with every state back at the encoder's start.
    bool exact() const noexcept {
        return !bad_ && pos_ == size_ &&
               std::all_of(x_, x_ + kLanes, [](std::uint32_t s) { return s == kRansLow; });
    }

private:
    // The word at the read position, or zeros past the end (the position keeps counting, exact() notices).
    std::uint32_t word() const noexcept {
        const std::uint8_t* q = data_ + std::min(pos_, size_);
        return q[0] | (std::uint32_t(q[1]) << 8);
    }
    const std::uint8_t* data_;
    std::size_t size_;
    std::size_t pos_ = 0;
    std::uint32_t x_[kLanes] = {0, 0, 0};
    bool bad_ = false;
};

// ------------------------------------------------------------------------------ dense model

// Magnitude symbol: 0 and 1 stand for themselves; a magnitude of bit length n >= 2 is 2(n-1) + its top
// mantissa bit, and its n-2 lower bits go raw. Magnitudes below 2^30 give symbols below 60.
constexpr int kSymbols = 60;
constexpr int kMaxBitLength = 30;
// Activity contexts: half-octave classes of 4(N+U) + (NW+NE+UW+UE+UN) + 2 parent (magnitudes of the
// neighbours in the previous row and slice and of the parent one level coarser). The previous coefficient
// W is left out on purpose: without it a row's contexts do not depend on the row being decoded, so the
// decoder's symbol chains for even and odd x run in parallel (measured: about 1 % larger files, several
// times faster decoding).
constexpr int kActivityContexts = 25;
constexpr int kSignContexts = 27 * 8; // signs of W, N, U (negative, zero, positive) per orientation
constexpr int kTableBitsPerEntry = 6;

inline int symbolOf(std::uint32_t u) {
    const int n = bitLength(u);
    return n <= 1 ? n : 2 * (n - 1) + static_cast<int>((u >> (n - 2)) & 1u);
}
// Smallest magnitude with symbol `sym`: stands in for the previous coefficient in the activity, because its
// raw mantissa bits are read in a later pass.
inline std::uint32_t symbolFloor(unsigned sym) {
    const std::uint32_t big = (2u | (sym & 1u)) << std::max(static_cast<int>(sym / 2) - 1, 0);
    const std::uint32_t small = 0u - static_cast<std::uint32_t>(sym < 2);
    return (sym & small) | (big & ~small);
}
inline int activityContext(std::uint32_t a) {
    // 0 for a = 0, 1 for a = 1, then two classes per octave (the bit below the leading one), capped.
    const int n = bitLength(a | 1u);
    const int half = static_cast<int>((a >> std::max(n - 2, 0)) & 1u) & static_cast<int>(a > 1);
    return std::min(2 * n - 1 + half, kActivityContexts - 1) & -static_cast<int>(a != 0);
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

// Walks the subbands of section s in raster order. Per row: side.rowFlag codes the "all zero" flag; for a
// non-zero row the walker first computes every coefficient's magnitude context and the neighbour part of
// its sign context from the previous row, the previous slice and the parent (no dependence on the row
// itself, so this loop has no serial chain), then side.row codes the row. Neighbours come from
// zero-padded copies of the current and the previous slice, so no loop has boundary tests.
struct SectionWalker {
    Dims brick;
    const std::vector<std::vector<SubbandBox>>& layout;
    std::size_t s;
    std::vector<std::int32_t> cur, prev;
    std::vector<std::uint32_t> parentRow;
    std::vector<std::uint32_t> activity;
    std::vector<std::uint16_t> signBase;

    template <class Side> void run(std::int32_t* c, Side& side) {
        const std::size_t sx = brick.x, sxy = brick.x * brick.y;
        for (const SubbandBox& b : layout[s]) {
            const SubbandBox* parent = nullptr;
            if (b.level > 0 && s >= 2)
                for (const SubbandBox& pb : layout[s - 1])
                    if (pb.orient == b.orient) parent = &pb;
            const std::size_t nx = b.x1 - b.x0, ny = b.y1 - b.y0, pitch = nx + 2;
            // Slice buffers: row 0 is the zero row above y0; row r+1 holds row y0+r; columns 0 and nx+1 are zero.
            cur.assign((ny + 1) * pitch, 0);
            prev.assign((ny + 1) * pitch, 0);
            parentRow.assign(nx, 0);
            activity.assign(nx, 0);
            signBase.assign(nx, 0);
            std::vector<std::uint8_t> rowZero(ny, 1), prevRowZero(ny, 1);
            const unsigned orient = static_cast<unsigned>(b.orient);
            for (std::size_t z = b.z0; z < b.z1; ++z) {
                for (std::size_t r = 0; r < ny; ++r) {
                    std::int32_t* row = c + z * sxy + (b.y0 + r) * sx + b.x0;
                    std::int32_t* m = cur.data() + (r + 1) * pitch + 1;
                    const unsigned rctx = orient * 4 + (r > 0 ? rowZero[r - 1] : 1u) + 2u * prevRowZero[r];
                    const bool zero = side.rowFlag(rctx, row, nx);
                    rowZero[r] = zero;
                    if (zero) {
                        std::fill(m, m + nx, 0);
                        continue;
                    }
                    if (parent) {
                        const std::size_t pz = std::min(parent->z0 + (z - b.z0) / 2, parent->z1 - 1);
                        const std::size_t py = std::min(parent->y0 + r / 2, parent->y1 - 1);
                        const std::int32_t* prow = c + pz * sxy + py * sx;
                        for (std::size_t x = 0; x < nx; ++x)
                            parentRow[x] = 2 * magnitude(prow[std::min(parent->x0 + x / 2, parent->x1 - 1)]);
                    }
                    const std::int32_t* n = m - pitch;
                    const std::int32_t* u = prev.data() + (r + 1) * pitch + 1;
                    const std::int32_t* un = u - pitch;
                    const unsigned sctx0 = orient * 27;
                    for (std::size_t x = 0; x < nx; ++x) {
                        const std::uint32_t a = 4 * (magnitude(n[x]) + magnitude(u[x])) + magnitude(n[x - 1]) +
                                                magnitude(n[x + 1]) + magnitude(u[x - 1]) + magnitude(u[x + 1]) +
                                                magnitude(un[x]) + parentRow[x];
                        activity[x] = a;
                        signBase[x] = static_cast<std::uint16_t>(sctx0 + 3 * signClass(n[x]) + 9 * signClass(u[x]));
                    }
                    side.row(activity.data(), signBase.data(), row, m, nx);
                }
                std::swap(cur, prev);
                std::swap(rowZero, prevRowZero);
            }
        }
    }
};

// Encoder pass 1: adaptive decisions become events at once; magnitude symbols are recorded as pending
// events (scaleBits 0, start = context * 64 + symbol) and resolved once the tables exist.
struct EncodeSide {
    DenseModel model;
    std::vector<RansEvent> events;
    std::array<std::array<std::uint32_t, kSymbols>, kActivityContexts> counts{};
    BitWriter raw;

    void binary(unsigned lane, BitModel& m, unsigned bit) {
        const auto p0 = static_cast<std::uint16_t>(m.p0);
        events.push_back(bit ? RansEvent{p0, static_cast<std::uint16_t>(kBinaryScale - p0), kBinaryScaleBits,
                                         static_cast<std::uint8_t>(lane)}
                             : RansEvent{0, p0, kBinaryScaleBits, static_cast<std::uint8_t>(lane)});
        m.p0 = bit ? m.p0 - (m.p0 >> 5) : m.p0 + ((kBinaryScale - m.p0) >> 5);
    }
    bool rowFlag(unsigned rctx, const std::int32_t* row, std::size_t nx) {
        bool zero = true;
        for (std::size_t x = 0; x < nx && zero; ++x)
            zero = row[x] == 0;
        binary(0, model.rows[rctx], zero ? 1u : 0u);
        return zero;
    }
    void row(const std::uint32_t* activity, const std::uint16_t* signBase, const std::int32_t* row, std::int32_t* m,
             std::size_t nx) {
        unsigned prevSym = 0;
        for (std::size_t x = 0; x < nx; ++x) {
            const std::int32_t v = row[x];
            const std::uint32_t u = magnitude(v);
            if (bitLength(u) > kMaxBitLength) throw Error("internal: wavelet coefficient magnitude out of range");
            const int sym = symbolOf(u);
            const auto lane = static_cast<std::uint8_t>(x & 1);
            const auto ctx = static_cast<std::size_t>(activityContext(activity[x] + 4 * symbolFloor(prevSym)));
            prevSym = static_cast<unsigned>(sym);
            ++counts[ctx][static_cast<std::size_t>(sym)];
            events.push_back({static_cast<std::uint16_t>(ctx * 64 + sym), 0, 0, lane});
            const int rawBits = std::max(sym / 2 - 1, 0);
            raw.put(u & ((1u << rawBits) - 1u), rawBits);
            m[x] = v;
        }
        // Signs of the row's non-zero coefficients follow its symbols (the decoder's second pass).
        for (std::size_t x = 0; x < nx; ++x)
            if (row[x] != 0) binary(kSignLane, model.signs[signBase[x] + signClass(m[x - 1])], row[x] < 0 ? 1u : 0u);
    }
};

// Decoder: per row, one branch-free pass decodes the magnitude symbols (even and odd x on separate states,
// positions and states held in locals so they stay in registers), a second pass the signs and raw mantissa
// bits of the non-zero ones.
struct DecodeSide {
    RansDecoder rans;
    RawReader raw;
    DenseModel model;
    std::array<const DecoderTable*, kActivityContexts> tables;
    std::vector<std::uint8_t> syms;

    bool rowFlag(unsigned rctx, std::int32_t* row, std::size_t nx) {
        RansDecoder r = rans;
        const bool zero = r.bit(0, model.rows[rctx]) != 0;
        rans = r;
        if (zero) std::fill(row, row + nx, 0);
        return zero;
    }
    void row(const std::uint32_t* activity, const std::uint16_t* signBase, std::int32_t* row, std::int32_t* m,
             std::size_t nx) {
        unsigned prevSym = 0;
        RansDecoder r = rans;
        if (syms.size() < nx) syms.resize(nx);
        std::uint8_t* sy = syms.data();
        // Pass 1, branch-free: the magnitude symbols.
        auto step = [&](std::size_t x, auto lane) {
            const DecoderTable& t =
                *tables[static_cast<std::size_t>(activityContext(activity[x] + 4 * symbolFloor(prevSym)))];
            const unsigned sym = t.lookup[r.slot(lane, kTableScaleBits)];
            r.advance(lane, kTableScaleBits, t.start[sym], t.freq[sym]);
            sy[x] = static_cast<std::uint8_t>(sym);
            prevSym = sym;
        };
        std::size_t x = 0;
        for (; x + 1 < nx; x += 2) {
            step(x, std::integral_constant<unsigned, 0>{});
            step(x + 1, std::integral_constant<unsigned, 1>{});
        }
        if (x < nx) step(x, std::integral_constant<unsigned, 0>{});
        // Pass 2: sign and raw mantissa bits of the non-zero coefficients. This branch is taken
        // predictably at low rates (mostly zeros) and in lossless data (mostly non-zero).
        RawReader b = raw;
        for (x = 0; x < nx; ++x) {
            const unsigned sym = sy[x];
            if (sym == 0) {
                m[x] = 0;
                row[x] = 0;
                continue;
            }
            const unsigned negative = r.bit(kSignLane, model.signs[signBase[x] + signClass(m[x - 1])]);
            const auto rawBits = static_cast<unsigned>(std::max(static_cast<int>(sym / 2) - 1, 0));
            const std::uint32_t low = b.get(rawBits);
            const std::uint32_t big = ((2u | (sym & 1u)) << rawBits) | low;
            const std::uint32_t u = sym < 2 ? sym : big;
            const std::int32_t v = negative ? -static_cast<std::int32_t>(u) : static_cast<std::int32_t>(u);
            m[x] = v;
            row[x] = v;
        }
        rans = r;
        raw = b;
    }
};

// Section layout (dense): u8 mode (0: one table, 1: one table per activity class, 2: every coefficient is
// zero and nothing follows), the tables (bit packed: per table 6 bits nsym, then nsym 6-bit quantised log
// weights; nsym 0 = unused table), varint size of the rANS stream, the rANS stream (varints of the three
// final states minus 2^16, then 16-bit words), the raw mantissa bits.
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
    std::size_t count = 0;
    for (const SubbandBox& b : layout[s])
        count += b.count();
    side.events.reserve(count + count / 2);
    SectionWalker walker{brick, layout, s, {}, {}, {}, {}, {}};
    // The walker writes back the value it was given, so the array is not modified.
    walker.run(const_cast<std::int32_t*>(coeffs.data()), side);
    side.raw.finish();

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
    std::array<std::uint32_t, kSymbols> merged{};
    double split = 0;
    for (const auto& cnt : side.counts) {
        split += cost(cnt);
        for (std::size_t i = 0; i < kSymbols; ++i)
            merged[i] += cnt[i];
    }
    const bool useContexts = split < cost(merged) + 6.0 * (kActivityContexts - 1);

    std::array<std::array<std::uint32_t, kSymbols>, kActivityContexts> counts{};
    if (useContexts)
        counts = side.counts;
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

    for (RansEvent& e : side.events)
        if (e.scaleBits == 0) {
            const std::size_t t = useContexts ? e.start / 64 : 0;
            const unsigned sym = e.start % 64;
            e = {tables[t].start[sym], tables[t].freq[sym], kTableScaleBits, e.lane};
        }
    std::vector<std::uint8_t> stream;
    ransEncode(side.events, stream);

    out.push_back(useContexts ? kContextTables : kOneTable);
    out.insert(out.end(), tableBits.bytes.begin(), tableBits.bytes.end());
    putVarint(out, stream.size());
    out.insert(out.end(), stream.begin(), stream.end());
    out.insert(out.end(), side.raw.bytes.begin(), side.raw.bytes.end());
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
    DecodeSide side{RansDecoder(ransBytes, n), RawReader(rawBytes, in.size() - head - n), {}, tablePtr, {}};
    SectionWalker walker{brick, layout, s, {}, {}, {}, {}, {}};
    walker.run(coeffs.data(), side);
    if (!side.rans.exact()) corrupt(what, "entropy stream does not end where its size says");
    if (!side.raw.exact()) corrupt(what, "raw bit stream length mismatch");
}

// ------------------------------------------------------------------------------ fast mode

void encodeFast(std::span<const std::int32_t> c, const std::vector<SubbandBox>& sec, Dims brick,
                std::vector<std::uint8_t>& out) {
    std::vector<std::uint32_t> folded;
    for (const SubbandBox& b : sec)
        for (std::size_t z = b.z0; z < b.z1; ++z)
            for (std::size_t y = b.y0; y < b.y1; ++y)
                for (std::size_t x = b.x0; x < b.x1; ++x) {
                    const std::int32_t v = c[(z * brick.y + y) * brick.x + x];
                    folded.push_back((static_cast<std::uint32_t>(v) << 1) ^
                                     static_cast<std::uint32_t>(v >> 31));
                }
    if (folded.empty()) return;
    const std::uint32_t maxV = *std::max_element(folded.begin(), folded.end());
    const int planes = maxV < 0x100u ? 1 : maxV < 0x10000u ? 2 : maxV < 0x1000000u ? 3 : 4;
    std::vector<std::uint8_t> raw(folded.size() * static_cast<std::size_t>(planes));
    for (int p = 0; p < planes; ++p)
        for (std::size_t i = 0; i < folded.size(); ++i)
            raw[static_cast<std::size_t>(p) * folded.size() + i] =
                static_cast<std::uint8_t>(folded[i] >> (8 * p));
    const std::size_t start = out.size();
    out.resize(start + 1 + ZSTD_compressBound(raw.size()));
    out[start] = static_cast<std::uint8_t>(planes);
    const std::size_t n =
        ZSTD_compress(out.data() + start + 1, out.size() - start - 1, raw.data(), raw.size(), 1);
    if (ZSTD_isError(n)) throw Error(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    out.resize(start + 1 + n);
}

void decodeFast(std::span<const std::uint8_t> in, std::span<std::int32_t> c,
                const std::vector<SubbandBox>& sec, Dims brick, const char* what) {
    std::size_t count = 0;
    for (const SubbandBox& b : sec)
        count += b.count();
    if (count == 0) {
        if (!in.empty()) throw IoError(std::string(what) + ": unexpected data in an empty section");
        return;
    }
    if (in.size() < 2 || in[0] < 1 || in[0] > 4)
        throw IoError(std::string(what) + ": invalid fast-mode section");
    const std::size_t planes = in[0];
    std::vector<std::uint8_t> raw(count * planes);
    const std::size_t n = ZSTD_decompress(raw.data(), raw.size(), in.data() + 1, in.size() - 1);
    if (ZSTD_isError(n) || n != raw.size())
        throw IoError(std::string(what) + ": zstd section does not decode to its size");
    std::size_t i = 0;
    for (const SubbandBox& b : sec)
        for (std::size_t z = b.z0; z < b.z1; ++z)
            for (std::size_t y = b.y0; y < b.y1; ++y)
                for (std::size_t x = b.x0; x < b.x1; ++x, ++i) {
                    std::uint32_t f = 0;
                    for (std::size_t p = 0; p < planes; ++p)
                        f |= static_cast<std::uint32_t>(raw[p * count + i]) << (8 * p);
                    c[(z * brick.y + y) * brick.x + x] =
                        static_cast<std::int32_t>((f >> 1) ^ (0u - (f & 1u)));
                }
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
        decodeFast(in, coeffs, layout[s], brick, what);
    }
}

} // namespace volcl
