// Node values of a brick render, from single-brick decodes (double arithmetic).
#include "host/render/bricks/BrickField.hpp"

#include "host/Error.hpp"
#include "wavelet/Codec.hpp"

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
        const Dims m = brick.dims();
        const double scale = 1.0 / double(std::size_t(1) << l);
        auto axis = [&](std::size_t x, std::size_t n, std::size_t& i0, std::size_t& i1, double& f) {
            const double u = std::min(double(x) * scale, double(n - 1));
            i0 = std::min(std::size_t(u), n > 1 ? n - 2 : 0);
            i1 = std::min(i0 + 1, n - 1);
            f = u - double(i0);
        };
        auto at = [&](std::size_t i, std::size_t j, std::size_t k) {
            return double(s[(k * m.y + j) * m.x + i]);
        };
        for (std::size_t k = 0; k < d.z; ++k) {
            std::size_t z0, z1;
            double fz;
            axis(k, m.z, z0, z1, fz);
            for (std::size_t j = 0; j < d.y; ++j) {
                std::size_t y0, y1;
                double fy;
                axis(j, m.y, y0, y1, fy);
                for (std::size_t i = 0; i < d.x; ++i) {
                    std::size_t x0, x1;
                    double fx;
                    axis(i, m.x, x0, x1, fx);
                    auto lx = [&](std::size_t y, std::size_t z) {
                        return at(x0, y, z) + fx * (at(x1, y, z) - at(x0, y, z));
                    };
                    const double c0 = lx(y0, z0) + fy * (lx(y1, z0) - lx(y0, z0));
                    const double c1 = lx(y0, z1) + fy * (lx(y1, z1) - lx(y0, z1));
                    v[out.index(o.x + i, o.y + j, o.z + k)] = float(c0 + fz * (c1 - c0));
                }
            }
        }
    }
    return out;
}

} // namespace volcl
