// Encoding and parsing of the correction payload.
#include "wavelet/quantise/Corrections.hpp"

#include "core/Error.hpp"
#include "wavelet/Varint.hpp"

#include <zstd.h>

#include <cmath>
#include <cstring>

namespace volcl::codec {

namespace {

// A varint of the corrections; IoError naming `what` when cut off or too long.
std::uint64_t readVarint(std::span<const std::uint8_t> in, std::size_t& pos, const std::string& what) {
    std::uint64_t v = 0;
    switch (getVarint(in, pos, v)) {
    case VarintStatus::Ok:
        return v;
    case VarintStatus::Truncated:
        throw IoError(what + ": truncated corrections");
    case VarintStatus::TooLong:
        break;
    }
    throw IoError(what + ": invalid corrections");
}

} // namespace

std::vector<std::uint8_t> encodeCorrections(const std::vector<Correction>& corr, ScalarType type) {
    std::vector<std::uint8_t> raw;
    putVarint(raw, corr.size());
    std::uint32_t prev = 0;
    for (const Correction& c : corr) {
        putVarint(raw, c.index - prev);
        prev = c.index;
        std::uint8_t bytes[8];
        switch (type) {
        case ScalarType::UInt8:
            bytes[0] = static_cast<std::uint8_t>(c.value);
            break;
        case ScalarType::UInt16: {
            auto v = static_cast<std::uint16_t>(c.value);
            std::memcpy(bytes, &v, 2);
            break;
        }
        case ScalarType::Int16: {
            auto v = static_cast<std::int16_t>(c.value);
            std::memcpy(bytes, &v, 2);
            break;
        }
        case ScalarType::Float32: {
            auto v = static_cast<float>(c.value);
            std::memcpy(bytes, &v, 4);
            break;
        }
        case ScalarType::Float64: // a float64 layer's voxels (wavelet/Float64Layer.hpp), bit for bit
            std::memcpy(bytes, &c.value, 8);
            break;
        }
        raw.insert(raw.end(), bytes, bytes + scalarSize(type));
    }
    std::vector<std::uint8_t> out(ZSTD_compressBound(raw.size()));
    const std::size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), 3);
    if (ZSTD_isError(n)) throw Error(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    out.resize(n);
    return out;
}

NonFiniteSplit splitNonFinite(const Volume& v, const VczHeader& h) {
    NonFiniteSplit out;
    if (v.type() != ScalarType::Float32) return out;
    const std::span<const float> in = v.values<float>();
    std::vector<std::size_t> holes;
    double sum = 0;
    std::size_t finite = 0;
    for (std::size_t i = 0; i < in.size(); ++i) {
        if (std::isfinite(in[i])) {
            sum += in[i];
            ++finite;
        } else {
            holes.push_back(i);
        }
    }
    if (holes.empty()) return out;
    out.count = holes.size();
    out.filled = v;
    std::span<float> f = out.filled.values<float>();
    // Start from the finite mean, then relax each hole toward its neighbours' average (Gauss-Seidel): the
    // fill meets the finite data smoothly and stays inside its range.
    const float mean = finite ? float(sum / double(finite)) : 0.0f;
    for (std::size_t i : holes)
        f[i] = mean;
    const Dims d = v.dims();
    const std::size_t sx = 1, sy = d.x, sz = d.x * d.y;
    for (int pass = 0; pass < 16; ++pass)
        for (std::size_t i : holes) {
            const std::size_t x = i % d.x, y = i / d.x % d.y, z = i / sz;
            double acc = 0;
            int n = 0;
            auto take = [&](bool ok, std::size_t j) {
                if (ok) {
                    acc += f[j];
                    ++n;
                }
            };
            take(x > 0, i - sx);
            take(x + 1 < d.x, i + sx);
            take(y > 0, i - sy);
            take(y + 1 < d.y, i + sy);
            take(z > 0, i - sz);
            take(z + 1 < d.z, i + sz);
            if (n) f[i] = float(acc / n);
        }
    // Each brick's holes in its dense order (x fastest), as the trial lists its corrections.
    out.exact.resize(h.brickCount());
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        const Dims o = h.brickOrigin(b), bd = h.brickDims(b);
        for (std::size_t z = 0; z < bd.z; ++z)
            for (std::size_t y = 0; y < bd.y; ++y)
                for (std::size_t x = 0; x < bd.x; ++x) {
                    const float s = in[v.index(o.x + x, o.y + y, o.z + z)];
                    if (!std::isfinite(s))
                        out.exact[b].push_back({std::uint32_t((z * bd.y + y) * bd.x + x), double(s)});
                }
    }
    return out;
}

std::vector<Correction> decodeCorrections(std::span<const std::uint8_t> in, ScalarType type,
                                          std::size_t brickVoxels, const std::string& what) {
    const unsigned long long size = ZSTD_getFrameContentSize(in.data(), in.size());
    const std::size_t maxSize = maxCorrectionListBytes(type, brickVoxels);
    if (size == ZSTD_CONTENTSIZE_ERROR || size == ZSTD_CONTENTSIZE_UNKNOWN || size > maxSize)
        throw IoError(what + ": invalid corrections");
    std::vector<std::uint8_t> raw(size);
    const std::size_t n = ZSTD_decompress(raw.data(), raw.size(), in.data(), in.size());
    if (ZSTD_isError(n) || n != raw.size()) throw IoError(what + ": invalid corrections");
    std::size_t pos = 0;
    const std::uint64_t count = readVarint(raw, pos, what);
    if (count > brickVoxels) throw IoError(what + ": invalid corrections");
    std::vector<Correction> out(count);
    std::uint64_t index = 0;
    for (Correction& c : out) {
        index += readVarint(raw, pos, what);
        if (index >= brickVoxels || raw.size() - pos < scalarSize(type))
            throw IoError(what + ": invalid corrections");
        c.index = static_cast<std::uint32_t>(index);
        const std::uint8_t* b = raw.data() + pos;
        switch (type) {
        case ScalarType::UInt8:
            c.value = b[0];
            break;
        case ScalarType::UInt16: {
            std::uint16_t v;
            std::memcpy(&v, b, 2);
            c.value = v;
            break;
        }
        case ScalarType::Int16: {
            std::int16_t v;
            std::memcpy(&v, b, 2);
            c.value = v;
            break;
        }
        case ScalarType::Float32: {
            float v;
            std::memcpy(&v, b, 4);
            c.value = v;
            break;
        }
        case ScalarType::Float64:
            std::memcpy(&c.value, b, 8);
            break;
        }
        pos += scalarSize(type);
    }
    return out;
}

} // namespace volcl::codec
