// Voxel-coded bricks: palette + zstd of the indices, or zstd of the raw byte planes; the per-brick chooser.
#include "wavelet/payload/VoxelBrick.hpp"

#include "core/Error.hpp"
#include "core/runtime/ParallelFor.hpp"
#include "wavelet/BrickVoxels.hpp"
#include "wavelet/Varint.hpp"

#include <zstd.h>

#include <algorithm>
#include <cstring>
#include <memory>

namespace volcl::codec {

namespace {

// The cheap pass (level 1) only decides whether a brick can win; the kept coding uses a thorough level.
// On aal's palette indices (7.1 MB in 64-voxel bricks) levels 1 / 9 / 12 / 15 / 19 give 150 / 106 / 104 / 85 /
// 78 KB (SZ3 at 40 dB: 266 KB) in 4 / 50 / 343 / 585 / 2352 ms of zstd on one core (load 11; docs/codec.md,
// "Never larger than lossless"): 9 keeps the encode near the wavelet's speed.
constexpr int kCheapLevel = 1;
constexpr int kThoroughLevel = 9;
// A brick whose cheap coding exceeds the limit by more than this factor is not tried thoroughly. With 1.1 a
// label brick whose set-partitioned wavelet payload was 387 B kept it though its voxels coded to 350 B
// (test_codec_voxel_bricks' uint16 labels); 1.5 cost ch2better --psnr 50 about 400 ms of level-9 zstd
// (one core, load 8), 1.2 no measurable time.
constexpr double kCheapSlack = 1.2;

// Palettes hold at most 2^16 values (u16 indices); float bricks first count the distinct values of a
// sample of this many voxels and take the raw coding when more than half of them differ.
constexpr std::size_t kMaxPalette = 65536;
constexpr std::size_t kFloatSample = 4096;

std::size_t valueBytes(ScalarType t) noexcept {
    return t == ScalarType::UInt8 ? 1 : t == ScalarType::Float32 ? 4 : 2;
}

struct ZstdContext {
    ZSTD_CCtx* c = ZSTD_createCCtx();
    ~ZstdContext() { ZSTD_freeCCtx(c); }
    ZstdContext() = default;
    ZstdContext(const ZstdContext&) = delete;
    ZstdContext& operator=(const ZstdContext&) = delete;
};

std::vector<std::uint8_t> zstdFrame(ZstdContext& z, std::span<const std::uint8_t> in, int level) {
    std::vector<std::uint8_t> out(ZSTD_compressBound(in.size()));
    ZSTD_CCtx_reset(z.c, ZSTD_reset_session_and_parameters);
    ZSTD_CCtx_setParameter(z.c, ZSTD_c_compressionLevel, level);
    ZSTD_CCtx_setPledgedSrcSize(z.c, in.size());
    const std::size_t n = ZSTD_compress2(z.c, out.data(), out.size(), in.data(), in.size());
    if (ZSTD_isError(n)) throw Error(std::string("internal: zstd: ") + ZSTD_getErrorName(n));
    out.resize(n);
    return out;
}

// The brick's distinct values, ascending, when there are at most kMaxPalette of them.
std::optional<std::vector<std::int32_t>> palette(std::span<const std::int32_t> vox, ScalarType t) {
    std::vector<std::int32_t> values;
    if (t != ScalarType::Float32) {
        // 16-bit values: a presence table (int16 offset by 2^15).
        const std::int32_t offset = t == ScalarType::Int16 ? 32768 : 0;
        std::vector<std::uint8_t> seen(65536, 0);
        for (std::int32_t v : vox)
            seen[std::size_t(v + offset)] = 1;
        for (std::size_t i = 0; i < seen.size(); ++i)
            if (seen[i]) values.push_back(std::int32_t(i) - offset);
        return values;
    }
    const std::size_t stride = std::max<std::size_t>(1, vox.size() / kFloatSample);
    for (std::size_t i = 0; i < vox.size(); i += stride)
        values.push_back(vox[i]);
    std::sort(values.begin(), values.end());
    if (std::size_t(std::unique(values.begin(), values.end()) - values.begin()) * 2 > values.size())
        return std::nullopt;
    values.assign(vox.begin(), vox.end());
    std::sort(values.begin(), values.end());
    values.erase(std::unique(values.begin(), values.end()), values.end());
    if (values.size() > kMaxPalette) return std::nullopt;
    return values;
}

void putValue(std::vector<std::uint8_t>& out, std::int32_t v, std::size_t bytes) {
    const auto u = static_cast<std::uint32_t>(v);
    for (std::size_t k = 0; k < bytes; ++k)
        out.push_back(static_cast<std::uint8_t>(u >> (8 * k)));
}

std::int32_t getValue(const std::uint8_t* p, ScalarType t) {
    switch (t) {
    case ScalarType::UInt8:
        return p[0];
    case ScalarType::UInt16:
        return std::int32_t(p[0]) | std::int32_t(p[1]) << 8;
    case ScalarType::Int16:
        return static_cast<std::int16_t>(std::uint16_t(p[0] | p[1] << 8));
    case ScalarType::Float32:
    case ScalarType::Float64: // not a brick type (bricks hold a float64 volume's float32 layer)
        break;
    }
    std::uint32_t u;
    std::memcpy(&u, p, 4); // little-endian host, as the rest of the container
    return static_cast<std::int32_t>(u);
}

// The symbols zstd codes and the prefix before them.
struct VoxelSymbols {
    std::vector<std::uint8_t> prefix, symbols;
};

VoxelSymbols voxelSymbols(std::span<const std::int32_t> vox, ScalarType t) {
    VoxelSymbols s;
    s.prefix.push_back(0);
    const std::size_t width = valueBytes(t);
    if (const auto values = palette(vox, t)) {
        s.prefix.push_back(std::uint8_t(VoxelBrickKind::Palette));
        putVarint(s.prefix, values->size());
        for (std::int32_t v : *values)
            putValue(s.prefix, v, width);
        const bool wide = values->size() > 256;
        s.symbols.resize(vox.size() * (wide ? 2 : 1));
        // Up to 16 bits a table gives each value's index; float values are searched.
        const std::int32_t offset = t == ScalarType::Int16 ? 32768 : 0;
        std::vector<std::uint16_t> table;
        if (t != ScalarType::Float32) {
            table.assign(65536, 0);
            for (std::size_t k = 0; k < values->size(); ++k)
                table[std::size_t((*values)[k] + offset)] = std::uint16_t(k);
        }
        for (std::size_t i = 0; i < vox.size(); ++i) {
            const std::size_t idx =
                table.empty()
                    ? std::size_t(std::lower_bound(values->begin(), values->end(), vox[i]) - values->begin())
                    : table[std::size_t(vox[i] + offset)];
            if (wide) {
                s.symbols[2 * i] = std::uint8_t(idx);
                s.symbols[2 * i + 1] = std::uint8_t(idx >> 8);
            } else {
                s.symbols[i] = std::uint8_t(idx);
            }
        }
        return s;
    }
    s.prefix.push_back(std::uint8_t(VoxelBrickKind::Raw));
    s.symbols.resize(vox.size() * width);
    for (std::size_t i = 0; i < vox.size(); ++i) {
        const auto u = static_cast<std::uint32_t>(vox[i]);
        for (std::size_t k = 0; k < width; ++k)
            s.symbols[k * vox.size() + i] = std::uint8_t(u >> (8 * k));
    }
    return s;
}

} // namespace

std::optional<std::vector<std::uint8_t>> encodeVoxelBrick(const Volume& v, Dims o, Dims d, std::size_t limit,
                                                          bool finiteOnly, VoxelBrickTrial* memo) {
    VoxelBrickTrial local;
    VoxelBrickTrial& t = memo ? *memo : local;
    if (t.checked && (t.origin != o || t.dims != d)) t = VoxelBrickTrial{};
    std::vector<std::int32_t> vox;
    auto voxels = [&]() -> const std::vector<std::int32_t>& {
        if (vox.empty()) vox = regionVoxels<std::int32_t>(v, o, d);
        return vox;
    };
    if (!t.checked) {
        t.origin = o;
        t.dims = d;
        t.checked = true;
        t.nonFinite = v.type() == ScalarType::Float32 && std::ranges::any_of(voxels(), [](std::int32_t bits) {
                          return (bits & 0x7f800000) == 0x7f800000;
                      });
    }
    if (finiteOnly && t.nonFinite) return std::nullopt;
    // The symbols are made again when a frame is still to be coded: kept in the memo they would add a copy
    // of the volume to an encode's memory.
    std::vector<std::uint8_t> symbols;
    auto symbolsToCode = [&]() -> const std::vector<std::uint8_t>& {
        if (symbols.empty()) {
            VoxelSymbols s = voxelSymbols(voxels(), v.type());
            t.prefix = std::move(s.prefix);
            symbols = std::move(s.symbols);
        }
        return symbols;
    };
    if (t.prefix.empty()) symbolsToCode();
    if (t.prefix.size() >= limit) return std::nullopt;
    ZstdContext z;
    if (!t.cheap) t.cheap = zstdFrame(z, symbolsToCode(), kCheapLevel);
    if (double(t.prefix.size() + t.cheap->size()) > kCheapSlack * double(limit)) return std::nullopt;
    if (!t.thorough) t.thorough = zstdFrame(z, symbolsToCode(), kThoroughLevel);
    const std::vector<std::uint8_t>& best = t.cheap->size() < t.thorough->size() ? *t.cheap : *t.thorough;
    if (t.prefix.size() + best.size() >= limit) return std::nullopt;
    std::vector<std::uint8_t> out = t.prefix;
    out.insert(out.end(), best.begin(), best.end());
    return out;
}

bool isVoxelBrick(std::span<const std::uint8_t> payload) noexcept {
    return !payload.empty() && payload[0] == 0;
}

std::vector<std::int32_t> decodeVoxelBrick(std::span<const std::uint8_t> p, ScalarType type, Dims d,
                                           const std::string& what) {
    if (p.size() < 2 || p[0] != 0) throw IoError(what + ": invalid voxel brick header");
    const std::size_t n = d.count(), width = valueBytes(type);
    std::size_t pos = 2;
    std::vector<std::int32_t> values;
    std::size_t symbolBytes = 0;
    if (p[1] == std::uint8_t(VoxelBrickKind::Palette)) {
        std::uint64_t k = 0;
        if (getVarint(p, pos, k) != VarintStatus::Ok || k == 0 || k > kMaxPalette || k > n)
            throw IoError(what + ": invalid palette size");
        if ((p.size() - pos) / width < k) throw IoError(what + ": truncated palette");
        values.resize(std::size_t(k));
        for (auto& v : values) {
            v = getValue(p.data() + pos, type);
            pos += width;
        }
        symbolBytes = n * (k > 256 ? 2 : 1);
    } else if (p[1] == std::uint8_t(VoxelBrickKind::Raw)) {
        symbolBytes = n * width;
    } else {
        throw IoError(what + ": unknown voxel brick kind " + std::to_string(p[1]));
    }
    const auto frame = p.subspan(pos);
    if (ZSTD_getFrameContentSize(frame.data(), frame.size()) != symbolBytes ||
        ZSTD_findFrameCompressedSize(frame.data(), frame.size()) != frame.size())
        throw IoError(what + ": corrupt voxel brick");
    std::vector<std::uint8_t> symbols(symbolBytes);
    const std::size_t got = ZSTD_decompress(symbols.data(), symbols.size(), frame.data(), frame.size());
    if (ZSTD_isError(got) || got != symbolBytes) throw IoError(what + ": corrupt voxel brick");
    std::vector<std::int32_t> vox(n);
    if (!values.empty()) {
        const bool wide = values.size() > 256;
        for (std::size_t i = 0; i < n; ++i) {
            const std::size_t idx =
                wide ? std::size_t(symbols[2 * i]) | std::size_t(symbols[2 * i + 1]) << 8 : symbols[i];
            if (idx >= values.size()) throw IoError(what + ": palette index out of range");
            vox[i] = values[idx];
        }
    } else {
        std::uint8_t b[4] = {0, 0, 0, 0};
        for (std::size_t i = 0; i < n; ++i) {
            for (std::size_t k = 0; k < width; ++k)
                b[k] = symbols[k * n + i];
            vox[i] = getValue(b, type);
        }
    }
    return vox;
}

std::size_t codeSmallerBricksAsVoxels(const Volume& frame, const VczHeader& h,
                                      std::vector<std::vector<std::uint8_t>>& payloads, unsigned threads,
                                      VoxelBrickTrials* memo) {
    std::vector<std::uint8_t> replaced(payloads.size(), 0);
    const bool finiteOnly = h.transform == TransformKind::FloatLifting;
    if (memo) memo->resize(payloads.size());
    parallelFor(payloads.size(), threads, [&](std::size_t b) {
        if (auto coded = encodeVoxelBrick(frame, h.brickOrigin(b), h.brickDims(b), payloads[b].size(),
                                          finiteOnly, memo ? &(*memo)[b] : nullptr)) {
            payloads[b] = std::move(*coded);
            replaced[b] = 1;
        }
    });
    return std::size_t(std::count(replaced.begin(), replaced.end(), std::uint8_t(1)));
}

} // namespace volcl::codec
