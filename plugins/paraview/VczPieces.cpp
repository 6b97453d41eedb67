// Splitting a .vcz across parallel ranks: slab extents aligned to brick layers, regions, bricks touched.
#include "plugins/paraview/VczPieces.hpp"

#include <algorithm>

namespace volcl::pieces {

Dims levelDims(const VczHeader& h, int level) {
    const std::size_t f = std::size_t(1) << level;
    auto up = [f](std::size_t v) { return (v + f - 1) / f; };
    return {up(h.dims.x), up(h.dims.y), up(h.dims.z)};
}

Extent pieceExtent(const VczHeader& h, int level, int piece, int pieces) {
    const Dims d = levelDims(h, level);
    const std::size_t f = std::size_t(1) << level;
    // Brick layers along z, in level samples: the brick edge shrinks with the level (at least one sample).
    const std::size_t layer = std::max<std::size_t>(1, h.brick.z / f);
    const std::size_t layers = (d.z + layer - 1) / layer;
    const std::size_t unit = layers >= std::size_t(pieces) ? layer : 1;
    const std::size_t units = (d.z + unit - 1) / unit;
    const std::size_t first = units * std::size_t(piece) / std::size_t(pieces);
    const std::size_t last = units * std::size_t(piece + 1) / std::size_t(pieces);
    Extent e{{0, 0, std::min(d.z, first * unit)}, {d.x, d.y, std::min(d.z, last * unit)}};
    return e;
}

Region regionOf(const VczHeader& h, int level, const Extent& e) {
    const std::size_t f = std::size_t(1) << level;
    auto hi = [f](std::size_t end, std::size_t full) { return std::min(full, (end - 1) * f + 1); };
    return {{e.lo.x * f, e.lo.y * f, e.lo.z * f},
            {hi(e.hi.x, h.dims.x), hi(e.hi.y, h.dims.y), hi(e.hi.z, h.dims.z)}};
}

std::vector<std::size_t> bricksOf(const VczHeader& h, const Region& r) {
    std::vector<std::size_t> which;
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        const Dims bo = h.brickOrigin(b), bd = h.brickDims(b);
        if (bo.x < r.hi.x && bo.x + bd.x > r.lo.x && bo.y < r.hi.y && bo.y + bd.y > r.lo.y && bo.z < r.hi.z &&
            bo.z + bd.z > r.lo.z)
            which.push_back(b);
    }
    return which;
}

} // namespace volcl::pieces
