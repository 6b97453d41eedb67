// Brick grouping of the transform stage.
#include "wavelet/transform/BrickTransform.hpp"

namespace volcl::codec {

std::vector<BrickGroup> groupBricks(const VczHeader& h, const std::vector<std::size_t>& which) {
    std::vector<BrickGroup> groups;
    for (std::size_t b : which) {
        const Dims d = h.brickDims(b);
        auto it =
            std::find_if(groups.begin(), groups.end(), [&](const BrickGroup& g) { return g.dims == d; });
        if (it == groups.end()) {
            groups.push_back({d, {}});
            it = groups.end() - 1;
        }
        it->bricks.push_back(b);
    }
    return groups;
}

std::vector<std::size_t> allBricks(const VczHeader& h) {
    std::vector<std::size_t> all(h.brickCount());
    for (std::size_t i = 0; i < all.size(); ++i)
        all[i] = i;
    return all;
}

// Each brick's first voxel relative to `first`, per batch group (VoxelVolume::origins).
std::vector<std::vector<Dims>> brickOrigins(const VczHeader& h, const std::vector<BrickGroup>& groups,
                                            Dims first) {
    std::vector<std::vector<Dims>> origins;
    for (const BrickGroup& g : groups) {
        auto& o = origins.emplace_back();
        for (std::size_t brick : g.bricks) {
            const Dims bo = h.brickOrigin(brick);
            o.push_back({bo.x - first.x, bo.y - first.y, bo.z - first.z});
        }
    }
    return origins;
}

} // namespace volcl::codec
