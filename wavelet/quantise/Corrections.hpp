// The correction payload of --max-error: voxels the quantiser left outside the bound, stored exactly
// (zstd over varint index gaps and raw values), and their application on decode.
#pragma once

#include "core/Volume.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace volcl::codec {

/// One exactly stored voxel: its index in the dense brick (x fastest) and its value.
struct Correction {
    std::uint32_t index;
    double value;
};

/// The brick's corrections (indices increasing) as a zstd frame.
std::vector<std::uint8_t> encodeCorrections(const std::vector<Correction>& corr, ScalarType type);
/// Largest decompressed correction list of a brick of `brickVoxels` voxels that decodeCorrections accepts:
/// the count and, per voxel, a varint index gap of at most 5 bytes and the voxel's value.
inline std::size_t maxCorrectionListBytes(ScalarType type, std::size_t brickVoxels) {
    return 10 + brickVoxels * (5 + scalarSize(type));
}
/// Parses a correction payload of a brick of `brickVoxels` voxels; IoError naming `what` when invalid.
std::vector<Correction> decodeCorrections(std::span<const std::uint8_t> in, ScalarType type,
                                          std::size_t brickVoxels, const std::string& what);

/// A frame's NaN/Inf voxels split off for lossy coding: `filled` holds a smooth fill in their place (the
/// finite neighbours' average, relaxed outward, so the wavelet spends few bits there and the finite
/// voxels' bound is untouched) and `exact[b]` lists brick b's NaN/Inf voxels, stored exactly as corrections.
struct NonFiniteSplit {
    Volume filled;
    std::vector<std::vector<Correction>> exact;
    std::size_t count = 0; ///< NaN/Inf voxels in the frame
};
/// Float frames only (other types hold no NaN); `count` 0 and `filled` empty when every voxel is finite.
NonFiniteSplit splitNonFinite(const Volume& v, const VczHeader& h);

// Brick b's exactly stored voxels (--max-error outliers) that fall into [a, e), at full resolution.
template <class V>
void applyCorrections(const VczHeader& h, std::size_t b, Dims a, Dims e, std::span<V> out, Dims outDims,
                      const std::vector<Correction>& corrections) {
    const Dims o = h.brickOrigin(b), d = h.brickDims(b);
    for (const Correction& c : corrections) {
        const std::size_t x = o.x + c.index % d.x, y = o.y + c.index / d.x % d.y,
                          z = o.z + c.index / (d.x * d.y);
        if (x >= a.x && x < e.x && y >= a.y && y < e.y && z >= a.z && z < e.z)
            out[((z - a.z) * outDims.y + (y - a.y)) * outDims.x + (x - a.x)] = static_cast<V>(c.value);
    }
}

} // namespace volcl::codec
