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

std::vector<std::vector<BrickGroup>> transformRounds(const std::vector<BrickGroup>& groups,
                                                     std::size_t (*strideBytes)(Dims), std::size_t budget) {
    std::vector<std::vector<BrickGroup>> rounds;
    std::size_t used = budget; // no open round yet
    for (const BrickGroup& g : groups) {
        const std::size_t bytes = strideBytes(g.dims);
        for (std::size_t i = 0; i < g.bricks.size();) {
            if (used + bytes > budget) {
                rounds.emplace_back();
                used = 0;
            }
            // As many of the group's bricks as fit the open round; at least one (a brick over the budget).
            const std::size_t fit = std::max<std::size_t>((budget - std::min(used, budget)) / bytes, 1);
            const std::size_t take = std::min(fit, g.bricks.size() - i);
            rounds.back().push_back(
                {g.dims,
                 {g.bricks.begin() + std::ptrdiff_t(i), g.bricks.begin() + std::ptrdiff_t(i + take)}});
            used += take * bytes;
            i += take;
        }
    }
    return rounds;
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
