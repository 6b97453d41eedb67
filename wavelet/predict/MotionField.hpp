// Block motion fields: vectors in half-voxel units, per-block prediction modes, and the block grid.
#pragma once

#include "core/Volume.hpp"

#include <cstdint>
#include <cstdlib>
#include <vector>

namespace volcl {

/// A displacement in half-voxel units: the block at voxel p is predicted from the reference at
/// p + (x, y, z) / 2. Integer-voxel vectors have even components.
struct MotionVector {
    std::int16_t x = 0, y = 0, z = 0;
    bool operator==(const MotionVector&) const = default;
    int l1() const noexcept { return std::abs(x) + std::abs(y) + std::abs(z); }
};

/// How one block is predicted. Intra predicts the block's mean value; Zero takes the forward reference
/// at the same place; Forward / Backward take one reference displaced by the block's vector for it;
/// Bidirectional averages the forward and backward predictions (B frames).
enum class BlockMode : std::uint8_t { Intra = 0, Zero = 1, Forward = 2, Backward = 3, Bidirectional = 4 };
constexpr int kBlockModeCount = 5;

/// The block grid over a volume: blocks of `size`^3 voxels from the origin; the last block along an
/// axis is partial when the dimension is not a multiple of the size.
struct BlockGrid {
    Dims volume;
    std::size_t size = 8;
    Dims blocks() const noexcept {
        return {(volume.x + size - 1) / size, (volume.y + size - 1) / size, (volume.z + size - 1) / size};
    }
    std::size_t count() const noexcept { return blocks().count(); }
    bool operator==(const BlockGrid&) const = default;
};

/// One frame's motion: per block (x fastest, then y, then z) a mode, the forward and backward
/// vectors (backward is empty for P frames) and the intra value (the block mean, used by Intra).
struct MotionField {
    BlockGrid grid;
    std::vector<BlockMode> modes;
    std::vector<MotionVector> forward, backward;
    std::vector<float> intraValue;
    bool bidirectional() const noexcept { return !backward.empty(); }
    bool operator==(const MotionField&) const = default;
};

} // namespace volcl
