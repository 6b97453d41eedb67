// Node values of a brick render, from single-brick decodes (double arithmetic).
#include "render/bricks/BrickField.hpp"

#include "core/Error.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/LodStatistics.hpp"

#include <algorithm>

namespace volcl {

Volume brickNodeValues(ComputeContext& cc, const VczReader& reader, std::size_t frame,
                       const std::vector<int>& levels, const std::vector<float>& standIn) {
    const VczHeader& h = reader.header();
    if (levels.size() != h.brickCount() || standIn.size() != h.brickCount())
        throw UsageError("brickNodeValues: one level and one stand-in per brick");
    Volume out(h.dims, ScalarType::Float32);
    out.spacing = h.spacing;
    out.origin = h.origin;
    auto v = out.values<float>();
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        const Dims o = h.brickOrigin(b), d = h.brickDims(b);
        if (levels[b] < 0) {
            for (std::size_t k = 0; k < d.z; ++k)
                for (std::size_t j = 0; j < d.y; ++j)
                    for (std::size_t i = 0; i < d.x; ++i)
                        v[out.index(o.x + i, o.y + j, o.z + k)] = standIn[b];
            continue;
        }
        const int l = levels[b];
        const Volume brick = reader.decodeBrick(cc, frame, b, l);
        const std::vector<float> s = brick.toFloat();
        forEachLevelValue(s, brick.dims(), d, l,
                          [&](std::size_t j, std::size_t k, std::span<const double> row) {
                              for (std::size_t i = 0; i < row.size(); ++i)
                                  v[out.index(o.x + i, o.y + j, o.z + k)] = float(row[i]);
                          });
    }
    return out;
}

} // namespace volcl
