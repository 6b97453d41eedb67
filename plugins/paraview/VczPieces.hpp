// Splitting a .vcz across parallel ranks: a rank's extent at a level, and the bricks that extent decodes.
#pragma once

#include "core/Volume.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <cstddef>
#include <vector>

namespace volcl::pieces {

/// Half-open sample-index box [lo, hi) on the grid of one level (level 0: full resolution).
struct Extent {
    Dims lo, hi;
    bool empty() const noexcept { return lo.x >= hi.x || lo.y >= hi.y || lo.z >= hi.z; }
    std::size_t count() const noexcept { return empty() ? 0 : (hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z); }
};

/// Samples per axis at `level` (what VczReader::decode returns for the whole volume).
Dims levelDims(const VczHeader& h, int level);
/// Piece `piece` of `pieces`: a slab along z made of whole brick layers where there are enough layers
/// (so no brick is decoded by two ranks), else of whole samples; empty when there are more pieces than
/// samples along z.
Extent pieceExtent(const VczHeader& h, int level, int piece, int pieces);
/// The full-resolution region whose decode at `level` yields exactly the samples of `e` (non-empty `e`).
Region regionOf(const VczHeader& h, int level, const Extent& e);
/// Bricks a decode of `r` touches (the same test VczReader::decode applies).
std::vector<std::size_t> bricksOf(const VczHeader& h, const Region& r);

} // namespace volcl::pieces
