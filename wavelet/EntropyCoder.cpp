// Entropy coders for wavelet coefficient sections.
//
// Dense mode is a hand-written binary range coder (LZMA's carry-less design with 11-bit adaptive
// probabilities): no Debian library offers context-adaptive binary coding with caller-defined contexts,
// and the context (magnitudes of the causal neighbours in the subband and of the parent coefficient one
// level coarser) is what makes wavelet coefficients compress better than xz. Fast mode uses libzstd.
#include "wavelet/EntropyCoder.hpp"

#include "host/Error.hpp"

#include <zstd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <string>

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

// ------------------------------------------------------------------------------ binary range coder

constexpr int kProbBits = 11;
constexpr std::uint16_t kProbInit = 1u << (kProbBits - 1);
constexpr int kAdaptShift = 4;
constexpr std::uint32_t kTop = 1u << 24;

class RangeEncoder {
public:
    explicit RangeEncoder(std::vector<std::uint8_t>& out) : out_(out) {}
    void bit(std::uint16_t& p, unsigned b) {
        const std::uint32_t bound = (range_ >> kProbBits) * p;
        if (!b) {
            range_ = bound;
            p += ((1u << kProbBits) - p) >> kAdaptShift;
        } else {
            low_ += bound;
            range_ -= bound;
            p -= p >> kAdaptShift;
        }
        while (range_ < kTop) {
            range_ <<= 8;
            shiftLow();
        }
    }
    void finish() {
        for (int i = 0; i < 5; ++i)
            shiftLow();
    }

private:
    void shiftLow() {
        if (static_cast<std::uint32_t>(low_) < 0xFF000000u || (low_ >> 32) != 0) {
            const auto carry = static_cast<std::uint8_t>(low_ >> 32);
            std::uint8_t temp = cache_;
            do {
                out_.push_back(static_cast<std::uint8_t>(temp + carry));
                temp = 0xFF;
            } while (--cacheSize_ != 0);
            cache_ = static_cast<std::uint8_t>(static_cast<std::uint32_t>(low_) >> 24);
        }
        ++cacheSize_;
        low_ = (low_ & 0x00FFFFFFu) << 8;
    }
    std::vector<std::uint8_t>& out_;
    std::uint64_t low_ = 0;
    std::uint32_t range_ = 0xFFFFFFFFu;
    std::uint8_t cache_ = 0;
    std::uint64_t cacheSize_ = 1;
};

class RangeDecoder {
public:
    RangeDecoder(std::span<const std::uint8_t> in, const char* what)
        : p_(in.data()), end_(in.data() + in.size()), what_(what) {
        for (int i = 0; i < 5; ++i)
            code_ = (code_ << 8) | next();
    }
    unsigned bit(std::uint16_t& p) {
        const std::uint32_t bound = (range_ >> kProbBits) * p;
        unsigned b;
        if (code_ < bound) {
            range_ = bound;
            p += ((1u << kProbBits) - p) >> kAdaptShift;
            b = 0;
        } else {
            code_ -= bound;
            range_ -= bound;
            p -= p >> kAdaptShift;
            b = 1;
        }
        if (range_ < kTop) {
            range_ <<= 8;
            code_ = (code_ << 8) | next();
        }
        return b;
    }
    /// The encoder flushes 5 bytes; reading further than that means the stream is inconsistent.
    void checkEnd() const {
        if (overrun_ > 0) throw IoError(std::string(what_) + ": entropy stream ends early (corrupted data)");
    }

private:
    std::uint32_t next() {
        if (p_ < end_) return *p_++;
        ++overrun_;
        return 0;
    }
    const std::uint8_t* p_;
    const std::uint8_t* end_;
    const char* what_;
    std::uint32_t range_ = 0xFFFFFFFFu, code_ = 0;
    std::size_t overrun_ = 0;
};

// ------------------------------------------------------------------------------ context model

constexpr int kNeighbourClasses = 12;
constexpr int kParentClasses = 4;
constexpr int kContexts = kNeighbourClasses * kParentClasses;
constexpr int kUnarySlots = 20;
constexpr int kMaxBits = 31; // magnitudes < 2^30 have at most 30 bits; 31 flags a corrupt stream

struct BandModel {
    std::array<std::array<std::uint16_t, kUnarySlots>, kContexts> unary;
    std::array<std::array<std::uint16_t, kMaxBits + 1>, kContexts / kParentClasses> mantissa;
    BandModel() {
        for (auto& a : unary)
            a.fill(kProbInit);
        for (auto& a : mantissa)
            a.fill(kProbInit);
    }
};

inline int bitLength(std::uint32_t v) {
    return v ? 32 - std::countl_zero(v) : 0;
}
inline std::uint32_t magnitude(std::int32_t v) {
    return v < 0 ? 0u - static_cast<std::uint32_t>(v) : static_cast<std::uint32_t>(v);
}

// Mantissa and sign bits are nearly equiprobable: they bypass the range coder into a plain bit stream,
// which costs no modelling and no renormalisation per bit.
class BitWriter {
public:
    void put(std::uint32_t v, int n) {
        acc_ |= std::uint64_t(v) << fill_;
        fill_ += n;
        while (fill_ >= 8) {
            bytes.push_back(static_cast<std::uint8_t>(acc_));
            acc_ >>= 8;
            fill_ -= 8;
        }
    }
    void finish() {
        if (fill_ > 0) bytes.push_back(static_cast<std::uint8_t>(acc_));
        acc_ = 0;
        fill_ = 0;
    }
    std::vector<std::uint8_t> bytes;

private:
    std::uint64_t acc_ = 0;
    int fill_ = 0;
};

class BitReader {
public:
    explicit BitReader(std::span<const std::uint8_t> in) : in_(in) {}
    std::uint32_t get(int n) {
        while (fill_ < n) {
            std::uint64_t b = 0;
            if (pos_ < in_.size())
                b = in_[pos_];
            else
                ++overrun_;
            ++pos_;
            acc_ |= b << fill_;
            fill_ += 8;
        }
        const auto v = static_cast<std::uint32_t>(acc_ & ((std::uint64_t(1) << n) - 1));
        acc_ >>= n;
        fill_ -= n;
        return v;
    }
    bool overrun() const noexcept { return overrun_ > 0; }
    bool fullyRead() const noexcept { return pos_ == in_.size(); }

private:
    std::span<const std::uint8_t> in_;
    std::size_t pos_ = 0;
    std::uint64_t acc_ = 0;
    int fill_ = 0;
    std::size_t overrun_ = 0;
};

// Adapters giving the encoder and decoder one interface, so one routine (codeDense) defines the bitstream
// for both directions: bit() codes `b` when encoding and returns the decoded bit when decoding.
struct EncodeSide {
    RangeEncoder& rc;
    BitWriter& raw;
    static constexpr bool decoding = false;
    unsigned bit(std::uint16_t& p, unsigned b) {
        rc.bit(p, b);
        return b;
    }
    std::uint32_t direct(std::uint32_t v, int n) {
        raw.put(v, n);
        return v;
    }
};
struct DecodeSide {
    RangeDecoder& rc;
    BitReader& raw;
    static constexpr bool decoding = true;
    unsigned bit(std::uint16_t& p, unsigned) { return rc.bit(p); }
    std::uint32_t direct(std::uint32_t, int n) { return raw.get(n); }
};

// Codes the subbands of section s in raster order. Per row: an "all zero" flag (context: were the rows
// before it in y and z zero); per coefficient: the magnitude class n = bit length, unary with adaptive
// probabilities chosen by the neighbour/parent context, then the first mantissa bit (adaptive), the
// rest of the mantissa and the sign (equiprobable).
template <class Side>
void codeDense(Side side, std::int32_t* c, Dims brick, const std::vector<std::vector<SubbandBox>>& layout,
               std::size_t s, const char* what) {
    std::vector<BandModel> models(8);
    std::array<std::array<std::uint16_t, 4>, 8> rowModels;
    for (auto& r : rowModels)
        r.fill(kProbInit);
    const std::size_t sx = brick.x, sxy = brick.x * brick.y;
    std::vector<std::uint8_t> prevSliceZero, sliceZero;
    for (const SubbandBox& b : layout[s]) {
        const SubbandBox* parent = nullptr;
        if (b.level > 0 && s >= 2)
            for (const SubbandBox& pb : layout[s - 1])
                if (pb.orient == b.orient) parent = &pb;
        BandModel& m = models[static_cast<std::size_t>(b.orient)];
        auto& rowModel = rowModels[static_cast<std::size_t>(b.orient)];
        const std::size_t ny = b.y1 - b.y0;
        prevSliceZero.assign(ny, 1);
        sliceZero.assign(ny, 1);
        for (std::size_t z = b.z0; z < b.z1; ++z) {
            for (std::size_t y = b.y0; y < b.y1; ++y) {
                const std::size_t row = z * sxy + y * sx;
                unsigned zero = 1;
                if (!Side::decoding)
                    for (std::size_t x = b.x0; x < b.x1 && zero; ++x)
                        zero = c[row + x] == 0;
                const unsigned rctx =
                    (y > b.y0 ? sliceZero[y - b.y0 - 1] : 1u) + 2u * prevSliceZero[y - b.y0];
                zero = side.bit(rowModel[rctx], zero);
                sliceZero[y - b.y0] = static_cast<std::uint8_t>(zero);
                if (zero) {
                    if (Side::decoding) std::fill(c + row + b.x0, c + row + b.x1, 0);
                    continue;
                }
                std::size_t pRow = 0;
                if (parent) {
                    const std::size_t pz = std::min(parent->z0 + (z - b.z0) / 2, parent->z1 - 1);
                    const std::size_t py = std::min(parent->y0 + (y - b.y0) / 2, parent->y1 - 1);
                    pRow = pz * sxy + py * sx;
                }
                for (std::size_t x = b.x0; x < b.x1; ++x) {
                    const std::size_t i = row + x;
                    std::uint32_t nb = 0;
                    if (x > b.x0) nb += magnitude(c[i - 1]);
                    if (y > b.y0) nb += magnitude(c[i - sx]);
                    if (z > b.z0) nb += magnitude(c[i - sxy]);
                    int pc = 0;
                    if (parent)
                        pc = std::min(bitLength(magnitude(
                                          c[pRow + std::min(parent->x0 + (x - b.x0) / 2, parent->x1 - 1)])),
                                      kParentClasses - 1);
                    const int nc = std::min(bitLength(nb), kNeighbourClasses - 1);
                    auto& un = m.unary[static_cast<std::size_t>(nc * kParentClasses + pc)];
                    const std::int32_t v = Side::decoding ? 0 : c[i];
                    const std::uint32_t u0 = magnitude(v);
                    const int n0 = bitLength(u0);
                    if (!Side::decoding && n0 >= kMaxBits)
                        throw Error("internal: wavelet coefficient magnitude out of range");
                    int n = 0;
                    while (side.bit(un[static_cast<std::size_t>(std::min(n, kUnarySlots - 1))],
                                    n < n0 ? 1u : 0u)) {
                        if (++n >= kMaxBits)
                            throw IoError(std::string(what) + ": invalid coefficient in entropy stream");
                    }
                    std::uint32_t u = 0;
                    if (n >= 1) {
                        u = 1;
                        if (n >= 2) {
                            u = (u << 1) |
                                side.bit(
                                    m.mantissa[static_cast<std::size_t>(nc)][static_cast<std::size_t>(n)],
                                    (u0 >> (n - 2)) & 1u);
                            if (n >= 3) u = (u << (n - 2)) | side.direct(u0 & ((1u << (n - 2)) - 1u), n - 2);
                        }
                        const unsigned negative = side.direct(v < 0 ? 1u : 0u, 1);
                        if (Side::decoding)
                            c[i] = negative ? -static_cast<std::int32_t>(u) : static_cast<std::int32_t>(u);
                    } else if (Side::decoding) {
                        c[i] = 0;
                    }
                }
            }
            std::swap(prevSliceZero, sliceZero);
        }
    }
}

// Dense section: u32 length of the range-coded stream, that stream, then the raw bit stream.
void encodeDense(std::span<const std::int32_t> c, Dims brick,
                 const std::vector<std::vector<SubbandBox>>& layout, std::size_t s,
                 std::vector<std::uint8_t>& out) {
    std::vector<std::uint8_t> coded;
    RangeEncoder rc(coded);
    BitWriter raw;
    // The encoding side only reads the coefficients.
    codeDense(EncodeSide{rc, raw}, const_cast<std::int32_t*>(c.data()), brick, layout, s, "encoder");
    rc.finish();
    raw.finish();
    const auto n = static_cast<std::uint32_t>(coded.size());
    const auto* p = reinterpret_cast<const std::uint8_t*>(&n);
    out.insert(out.end(), p, p + 4);
    out.insert(out.end(), coded.begin(), coded.end());
    out.insert(out.end(), raw.bytes.begin(), raw.bytes.end());
}

void decodeDense(std::span<const std::uint8_t> in, std::span<std::int32_t> c, Dims brick,
                 const std::vector<std::vector<SubbandBox>>& layout, std::size_t s, const char* what) {
    std::uint32_t n = 0;
    if (in.size() < 4) throw IoError(std::string(what) + ": truncated entropy section");
    std::memcpy(&n, in.data(), 4);
    if (n > in.size() - 4) throw IoError(std::string(what) + ": entropy section sizes exceed the brick");
    RangeDecoder rc(in.subspan(4, n), what);
    BitReader raw(in.subspan(4 + n));
    codeDense(DecodeSide{rc, raw}, c.data(), brick, layout, s, what);
    rc.checkEnd();
    if (raw.overrun() || !raw.fullyRead())
        throw IoError(std::string(what) + ": raw bit stream length mismatch (corrupted data)");
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
        if (!in.empty()) throw IoError(std::string(what) + ": unexpected data in an empty section");
        return;
    }
    if (mode == EntropyMode::Dense) {
        decodeDense(in, coeffs, brick, layout, s, what);
    } else {
        decodeFast(in, coeffs, layout[s], brick, what);
    }
}

} // namespace volcl
