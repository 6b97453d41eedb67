// Encoding and parsing of the correction payload.
#include "wavelet/quantise/Corrections.hpp"

#include "core/Error.hpp"
#include "wavelet/Varint.hpp"

#include <zstd.h>

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
        std::uint8_t bytes[4];
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
        }
        raw.insert(raw.end(), bytes, bytes + scalarSize(type));
    }
    std::vector<std::uint8_t> out(ZSTD_compressBound(raw.size()));
    const std::size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), 3);
    if (ZSTD_isError(n)) throw Error(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    out.resize(n);
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
        }
        pos += scalarSize(type);
    }
    return out;
}

} // namespace volcl::codec
