// Grid renderer internals: value range, macrocell min/max and emptiness, corner copy, kernel parameters.
#include "render/grid/GridDetail.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "render/FrameParams.hpp"
#include "render/grid/GradientCache.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl::grid_detail {

ValueRange valueRange(const Volume& volume) {
    ValueRange r{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
    for (std::size_t i = 0; i < volume.voxelCount(); ++i) {
        const double v = volume.valueAt(i);
        if (!std::isfinite(v)) continue;
        r.min = std::min(r.min, v);
        r.max = std::max(r.max, v);
    }
    if (r.min > r.max) r = {0.0, 0.0};
    return r;
}

std::size_t nonFiniteCount(const Volume& volume) {
    if (volume.type() != ScalarType::Float32) return 0;
    std::size_t n = 0;
    for (float v : volume.values<float>())
        n += std::isfinite(v) ? 0 : 1;
    return n;
}

MacrocellGrid coarsenMacrocells(const MacrocellGrid& fine, unsigned factor) {
    if (factor <= 1) return fine;
    MacrocellGrid g;
    g.edge = fine.edge * factor;
    g.nx = (fine.nx + factor - 1) / factor;
    g.ny = (fine.ny + factor - 1) / factor;
    g.nz = (fine.nz + factor - 1) / factor;
    const std::size_t count = std::size_t(g.nx) * g.ny * g.nz;
    g.min.assign(count, std::numeric_limits<float>::infinity());
    g.max.assign(count, -std::numeric_limits<float>::infinity());
    g.nonFinite.assign(count, 0);
    for (unsigned z = 0; z < fine.nz; ++z)
        for (unsigned y = 0; y < fine.ny; ++y)
            for (unsigned x = 0; x < fine.nx; ++x) {
                const std::size_t f = (std::size_t(z) * fine.ny + y) * fine.nx + x;
                const std::size_t c = (std::size_t(z / factor) * g.ny + y / factor) * g.nx + x / factor;
                g.min[c] = std::min(g.min[c], fine.min[f]);
                g.max[c] = std::max(g.max[c], fine.max[f]);
                if (!fine.nonFinite.empty()) g.nonFinite[c] |= fine.nonFinite[f]; // spline grids have none
            }
    return g;
}

MacrocellGrid buildMacrocells(const Volume& volume, unsigned edge) {
    const Dims& d = volume.dims();
    MacrocellGrid g;
    g.edge = edge;
    auto cells = [edge](std::size_t n) {
        return unsigned(std::max<std::size_t>(1, (n - 1 + edge - 1) / edge));
    };
    g.nx = cells(d.x);
    g.ny = cells(d.y);
    g.nz = cells(d.z);
    const std::size_t count = std::size_t(g.nx) * g.ny * g.nz;
    g.min.assign(count, std::numeric_limits<float>::infinity());
    g.max.assign(count, -std::numeric_limits<float>::infinity());
    g.nonFinite.assign(count, 0);
    const std::vector<float> v = volume.toFloat();
    // Each voxel belongs to the cells whose closed range holds it (two along an axis on a shared face).
    auto range = [edge](std::size_t i, unsigned n, unsigned& c0, unsigned& c1) {
        c1 = std::min<unsigned>(unsigned(i / edge), n - 1);
        c0 = (i % edge == 0 && i > 0) ? unsigned(i / edge) - 1 : c1;
    };
    for (std::size_t k = 0; k < d.z; ++k) {
        unsigned z0, z1;
        range(k, g.nz, z0, z1);
        for (std::size_t j = 0; j < d.y; ++j) {
            unsigned y0, y1;
            range(j, g.ny, y0, y1);
            const float* row = v.data() + volume.index(0, j, k);
            for (std::size_t i = 0; i < d.x; ++i) {
                unsigned x0, x1;
                range(i, g.nx, x0, x1);
                const float s = row[i];
                // A NaN/Inf voxel marks its cells instead of entering min/max (where NaN would stick or
                // vanish depending on the order of comparison).
                const bool finite = std::isfinite(s);
                for (unsigned cz = z0; cz <= z1; ++cz)
                    for (unsigned cy = y0; cy <= y1; ++cy)
                        for (unsigned cx = x0; cx <= x1; ++cx) {
                            const std::size_t c = (std::size_t(cz) * g.ny + cy) * g.nx + cx;
                            if (!finite) {
                                g.nonFinite[c] = 1;
                                continue;
                            }
                            g.min[c] = std::min(g.min[c], s);
                            g.max[c] = std::max(g.max[c], s);
                        }
            }
        }
    }
    return g;
}

std::vector<unsigned char> cellCorners(const Volume& volume) {
    if (volume.type() != ScalarType::UInt8) throw UsageError("cellCorners: uint8 volumes only");
    const auto d = volume.dims();
    const std::size_t nx = d.x, ny = d.y, nz = d.z;
    const std::size_t bx = (nx + 3) / 4, by = (ny + 3) / 4, bz = (nz + 3) / 4;
    const auto v = volume.values<std::uint8_t>();
    std::vector<unsigned char> out(bx * by * bz * 64 * 8, 0);
    for (std::size_t z = 0; z < nz; ++z) {
        const std::size_t z1 = std::min(z + 1, nz - 1);
        for (std::size_t y = 0; y < ny; ++y) {
            const std::size_t y1 = std::min(y + 1, ny - 1);
            const std::uint8_t* r00 = &v[(z * ny + y) * nx];
            const std::uint8_t* r10 = &v[(z * ny + y1) * nx];
            const std::uint8_t* r01 = &v[(z1 * ny + y) * nx];
            const std::uint8_t* r11 = &v[(z1 * ny + y1) * nx];
            for (std::size_t x = 0; x < nx; ++x) {
                const std::size_t x1 = std::min(x + 1, nx - 1);
                const std::size_t cell =
                    (((z / 4) * by + y / 4) * bx + x / 4) * 64 + (z % 4) * 16 + (y % 4) * 4 + x % 4;
                unsigned char* o = &out[cell * 8];
                o[0] = r00[x];
                o[1] = r00[x1];
                o[2] = r10[x];
                o[3] = r10[x1];
                o[4] = r01[x];
                o[5] = r01[x1];
                o[6] = r11[x];
                o[7] = r11[x1];
            }
        }
    }
    return out;
}

double maxExtinctionOver(const TransferFunction& tf, double a, double b) {
    double m = std::max(tf.extinctionAt(a), tf.extinctionAt(b));
    // Right limit at a (a step exactly at a holds above a) and every point inside.
    for (const auto& p : tf.extinction)
        if (p.s >= a && p.s <= b) m = std::max(m, p.tau);
    return m;
}

ValueRange tableNodeSpan(const TransferFunction& tf, double a, double b, int tableNodes) {
    if (tableNodes <= 1) return {a, b};
    // A table lookup clamps to the domain and blends the neighbouring nodes.
    const double lo = tf.domain[0], hi = tf.domain[1], h = (hi - lo) / double(tableNodes - 1);
    return {lo + std::floor((std::clamp(a, lo, hi) - lo) / h) * h,
            lo + std::ceil((std::clamp(b, lo, hi) - lo) / h) * h};
}

std::vector<unsigned char> emptyMacrocells(const MacrocellGrid& grid, const TransferFunction& tf,
                                           const std::vector<double>& isoValues, bool isoOnly, int tableNodes,
                                           bool nanVisible) {
    std::vector<unsigned char> empty(grid.min.size(), 0);
    for (std::size_t c = 0; c < empty.size(); ++c) {
        const double a = grid.min[c], b = grid.max[c];
        const bool nonFinite = c < grid.nonFinite.size() && grid.nonFinite[c];
        if (a > b) { // no finite voxel: only the NaN colour can show
            empty[c] = nonFinite && nanVisible && !isoOnly ? 0 : 1;
            continue;
        }
        bool visible = nonFinite && nanVisible && !isoOnly;
        for (double iso : isoValues)
            visible |= iso > a && iso <= b;
        if (!isoOnly && !visible) {
            const ValueRange r = tableNodeSpan(tf, a, b, tableNodes);
            visible = maxExtinctionOver(tf, r.min, r.max) > 0.0;
        }
        empty[c] = visible ? 0 : 1;
    }
    return empty;
}

double gradientThreshold(const Volume& volume) {
    const ValueRange r = valueRange(volume);
    const double s = std::max({volume.spacing[0], volume.spacing[1], volume.spacing[2]});
    return 1e-6 * std::max(r.max - r.min, 1e-30) / s;
}

double trilinear(const std::vector<float>& values, const std::array<std::size_t, 3>& n, const Vec3& p) {
    std::size_t i0[3], i1[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
        const double hi = double(n[a] - 1);
        const double x = std::clamp(p[a], 0.0, hi);
        std::size_t i = std::size_t(std::floor(x));
        i = n[a] >= 2 ? std::min(i, n[a] - 2) : 0;
        i0[a] = i;
        i1[a] = std::min(i + 1, n[a] - 1);
        f[a] = x - double(i);
    }
    auto at = [&](std::size_t i, std::size_t j, std::size_t k) -> double {
        return values[(k * n[1] + j) * n[0] + i];
    };
    auto lerp = [](double a, double b, double t) { return a + t * (b - a); };
    const double c00 = lerp(at(i0[0], i0[1], i0[2]), at(i1[0], i0[1], i0[2]), f[0]);
    const double c10 = lerp(at(i0[0], i1[1], i0[2]), at(i1[0], i1[1], i0[2]), f[0]);
    const double c01 = lerp(at(i0[0], i0[1], i1[2]), at(i1[0], i0[1], i1[2]), f[0]);
    const double c11 = lerp(at(i0[0], i1[1], i1[2]), at(i1[0], i1[1], i1[2]), f[0]);
    return lerp(lerp(c00, c10, f[1]), lerp(c01, c11, f[1]), f[2]);
}

VolclGridParams gridParams(const Volume& volume, const MacrocellGrid& grid) {
    VolclGridParams p{};
    auto put = [](float* dst, const Vec3& v) {
        for (int i = 0; i < 3; ++i)
            dst[i] = static_cast<float>(v[std::size_t(i)]);
        dst[3] = 0.0f;
    };
    put(p.origin, volume.origin);
    put(p.spacing, volume.spacing);
    put(p.invSpacing, {1.0 / volume.spacing[0], 1.0 / volume.spacing[1], 1.0 / volume.spacing[2]});
    const Dims& d = volume.dims();
    p.dims[0] = volcl_uint(d.x);
    p.dims[1] = volcl_uint(d.y);
    p.dims[2] = volcl_uint(d.z);
    p.macroDims[0] = grid.nx;
    p.macroDims[1] = grid.ny;
    p.macroDims[2] = grid.nz;
    p.macroDims[3] = grid.edge;
    return p;
}

VolclGridRenderParams makeParams(const Scene& scene, const Camera& cam, const Volume& volume,
                                 const ValueRange& range, const TransferFunction& tf, const EffectPlan& plan,
                                 const MacrocellGrid& grid, std::size_t knotCount, int tableLengths) {
    VolclGridRenderParams p{};
    p.camera = cameraParams(cam, scene.width, scene.height);
    p.clip = clipParams(plan.clipPlanes);
    p.march = marchParams(scene, range);
    p.tf = tfParams(scene, tf, knotCount, tableLengths);
    p.lighting = lightingParams(scene, gradientThreshold(volume));
    p.iso = isoParams(plan);
    p.grid = gridParams(volume, grid);
    p.grid.gradientMax = gradientCacheScale(volume.spacing, range);
    return p;
}

} // namespace volcl::grid_detail
