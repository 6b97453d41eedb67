// Working set and level of detail of a compressed-brick frame: reachability, TF emptiness, error estimate.
#include "render/bricks/BrickLod.hpp"

#include "core/Error.hpp"
#include "render/VecMath.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// Largest |slope| of a piecewise-linear function (points (s, value(i))) over [a, b]; steps inside are
/// infinite, the constant continuations beyond the first and last point are flat.
template <class Points, class Value> double maxSlope(const Points& pts, Value value, double a, double b) {
    double m = 0;
    for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
        const double s0 = pts[i].s, s1 = pts[i + 1].s;
        if (s1 < a || s0 > b) continue;
        const double dv = value(i + 1) - value(i);
        if (s1 == s0) {
            if (dv != 0) return kInf;
            continue;
        }
        m = std::max(m, std::abs(dv / (s1 - s0)));
    }
    return m;
}

/// Lossy files' guaranteed absolute bound on every voxel (0 for lossless; PSNR, rate and point-wise
/// relative targets give none that is absolute; a series' relative bound is over each frame's range, at
/// most the file's).
double codingBound(const VczHeader& h) {
    if (h.rate == RateMode::MaxError) return h.rateTarget;
    if (h.rate == RateMode::RelError) return h.rateTarget * (h.valueMax - h.valueMin);
    return 0.0;
}

/// The bound on decoded voxels whose inputs lie in [lo, hi]: the absolute one, or R x the largest magnitude
/// there for a point-wise relative bound.
double codingBound(const VczHeader& h, double lo, double hi) {
    if (h.rate == RateMode::PwRelError) return h.rateTarget * std::max(std::abs(lo), std::abs(hi));
    return codingBound(h);
}

bool uniformExact(const VczHeader& h, std::size_t frame, std::size_t b) {
    const VczBrickEntry& e = h.bricks[frame][b];
    return h.rate == RateMode::Lossless && e.min == e.max;
}

ValueRange levelRange(const VczHeader& h, const LodStatistics* stats, std::size_t frame, std::size_t b,
                      int level) {
    if (stats && stats->has(frame)) {
        const BrickLevelStats& s = stats->at(frame, b, level);
        return {s.min, s.max};
    }
    const VczBrickEntry& e = h.bricks[frame][b];
    const double w = codingBound(h, e.min, e.max);
    return {e.min - w, e.max + w};
}

/// Range of the samples on the brick's low faces (what a neighbour's cells read); the whole range without
/// statistics.
ValueRange faceRange(const VczHeader& h, const LodStatistics* stats, std::size_t frame, std::size_t b,
                     int level) {
    if (stats && stats->has(frame)) {
        const BrickLevelStats& s = stats->at(frame, b, level);
        return {s.faceMin, s.faceMax};
    }
    return levelRange(h, stats, frame, b, level);
}

/// Hull of the value ranges of brick b and its 26 neighbours, over every level (the input's range too).
ValueRange neighbourhoodRange(const VczHeader& h, const LodStatistics* stats, std::size_t frame,
                              std::size_t b) {
    const Dims g = h.brickGrid();
    const std::size_t bx = b % g.x, by = b / g.x % g.y, bz = b / (g.x * g.y);
    const int levels = stats && stats->has(frame) ? stats->levels : 0;
    ValueRange r{kInf, -kInf};
    for (std::size_t z = bz > 0 ? bz - 1 : 0; z <= std::min(bz + 1, g.z - 1); ++z)
        for (std::size_t y = by > 0 ? by - 1 : 0; y <= std::min(by + 1, g.y - 1); ++y)
            for (std::size_t x = bx > 0 ? bx - 1 : 0; x <= std::min(bx + 1, g.x - 1); ++x) {
                const std::size_t n = (z * g.y + y) * g.x + x;
                r.min = std::min(r.min, h.bricks[frame][n].min);
                r.max = std::max(r.max, h.bricks[frame][n].max);
                for (int l = 0; l <= levels; ++l) {
                    const ValueRange v = levelRange(h, stats, frame, n, l);
                    r.min = std::min(r.min, v.min);
                    r.max = std::max(r.max, v.max);
                }
            }
    return r;
}

double dataError(const VczHeader& h, const LodStatistics* stats, std::size_t frame, std::size_t b,
                 int level) {
    const VczBrickEntry& e = h.bricks[frame][b];
    const double bound = codingBound(h, e.min, e.max);
    if (stats && stats->has(frame))
        return std::max<double>(stats->at(frame, b, level).rms, level == 0 ? bound : 0.0);
    if (uniformExact(h, frame, b)) return 0.0; // every filter's low band of a constant is the constant
    return level == 0 ? bound : kInf;
}

struct ViewFrame {
    Vec3 f, r, u;
};

ViewFrame viewFrame(const Camera& c) {
    ViewFrame v;
    v.f = normalized(sub(c.target, c.eye));
    v.r = normalized(cross(v.f, c.up));
    v.u = cross(v.r, v.f);
    return v;
}

/// World corners of brick b's voxel box grown by `grow` voxels.
std::array<Vec3, 8> brickCorners(const VczHeader& h, std::size_t b, double grow) {
    const Dims o = h.brickOrigin(b), d = h.brickDims(b);
    const double lo[3] = {double(o.x) - grow, double(o.y) - grow, double(o.z) - grow};
    const double hi[3] = {double(o.x + d.x - 1) + grow, double(o.y + d.y - 1) + grow,
                          double(o.z + d.z - 1) + grow};
    std::array<Vec3, 8> c;
    for (int i = 0; i < 8; ++i)
        for (int a = 0; a < 3; ++a)
            c[std::size_t(i)][std::size_t(a)] =
                h.origin[std::size_t(a)] + ((i >> a) & 1 ? hi[a] : lo[a]) * h.spacing[std::size_t(a)];
    return c;
}

/// World size of one pixel at brick b (0 when the brick reaches the eye's plane: no coarsening).
double pixelSizeAt(const VczHeader& h, std::size_t b, const BrickView& view) {
    const Camera& c = view.camera;
    if (c.projection == Projection::Orthographic) return c.height / double(view.height);
    const ViewFrame v = viewFrame(c);
    double depth = kInf;
    for (const Vec3& p : brickCorners(h, b, 0.0))
        depth = std::min(depth, dot(sub(p, c.eye), v.f));
    if (!(depth > 0)) return 0.0;
    const double pi = 3.14159265358979323846;
    return depth * 2.0 * std::tan(c.fovYDeg * pi / 360.0) / double(view.height);
}

} // namespace

Dims brickSamples(const VczHeader& h, std::size_t b, int level) {
    const Dims d = h.brickDims(b);
    const std::size_t s = std::size_t(1) << level;
    return {(d.x + s - 1) / s, (d.y + s - 1) / s, (d.z + s - 1) / s};
}

double tfSensitivity(const TransferFunction& tf, double a, double b, double h) {
    const double kt = maxSlope(
        tf.extinction, [&](std::size_t i) { return tf.extinction[i].tau; }, a, b);
    double kc = 0;
    for (std::size_t ch = 0; ch < 3; ++ch)
        kc = std::max(kc, maxSlope(
                              tf.color, [&](std::size_t i) { return tf.color[i].rgb[ch]; }, a, b));
    const double tmax = grid_detail::maxExtinctionOver(tf, a, b);
    if (tmax == 0 && kt == 0) return 0.0; // transparent throughout: nothing changes
    return h * kt + kc * (1.0 - std::exp(-tmax * h));
}

double brickError(const VczHeader& h, const LodStatistics* stats, std::size_t frame, std::size_t b, int level,
                  const TransferFunction& tf, const BrickView& view) {
    const double e = dataError(h, stats, frame, b, level);
    if (e == 0) return 0.0;
    // The samples a coarser brick changes lie in its own cells and in the cells across its faces, which
    // interpolate its node values with its neighbours'; a pre-integrated segment from there integrates the TF
    // between two such values. Every field stays inside its measured ranges (a trilinear interpolation of
    // samples stays inside their range), so all those values lie in the hull of the brick's and its 26
    // neighbours' ranges at every level (a neighbour's level is not known here): the TF's largest slope there
    // bounds the change per data unit (mean value theorem). The hull is widened by the coding bound (a lossy
    // file's decoded voxels may leave the input's range by that much) and to the pre-integration table nodes
    // the lookups blend, not by the deviation itself: where no value near the brick reaches a narrow TF peak,
    // coarsening it does not change the image.
    const ValueRange hull0 = neighbourhoodRange(h, stats, frame, b);
    const double spacing = std::max({h.spacing[0], h.spacing[1], h.spacing[2]});
    const double w = codingBound(h, hull0.min, hull0.max);
    const ValueRange hull = grid_detail::tableNodeSpan(tf, hull0.min - w, hull0.max + w, view.tableNodes);
    const double lo = hull.min, hi = hull.max;
    double sens = tfSensitivity(tf, lo, hi, spacing);
    for (double iso : view.isoValues)
        if (iso >= lo && iso <= hi) sens = kInf; // a surface inside the brick moves with the data
    if (sens == 0) return 0.0;
    const double pixel = pixelSizeAt(h, b, view);
    const double cellPixels = pixel > 0 ? double(std::size_t(1) << level) * spacing / pixel : kInf;
    return e * sens * cellPixels;
}

namespace {

/// Rectangle the corners project to on the image plane, in the camera's units (world units for orthographic,
/// tangent of the angle for perspective), and the image's half extents in the same units.
struct ProjectedRect {
    double x0 = kInf, x1 = -kInf, y0 = kInf, y1 = -kInf, dmax = -kInf, hw = 0, hh = 0;
    bool behind = false; ///< a corner lies at or behind the eye's plane (perspective)
};

ProjectedRect project(const std::array<Vec3, 8>& corners, const BrickView& view) {
    const Camera& c = view.camera;
    const ViewFrame v = viewFrame(c);
    ProjectedRect r;
    for (const Vec3& p : corners) {
        const Vec3 rel = sub(p, c.eye);
        const double d = dot(rel, v.f);
        r.dmax = std::max(r.dmax, d);
        double x = dot(rel, v.r), y = dot(rel, v.u);
        if (c.projection == Projection::Perspective) {
            if (d <= 1e-9) {
                r.behind = true;
                continue;
            }
            x /= d;
            y /= d;
        }
        r.x0 = std::min(r.x0, x);
        r.x1 = std::max(r.x1, x);
        r.y0 = std::min(r.y0, y);
        r.y1 = std::max(r.y1, y);
    }
    r.hh = c.projection == Projection::Orthographic ? 0.5 * c.height
                                                    : std::tan(c.fovYDeg * 3.14159265358979323846 / 360.0);
    r.hw = r.hh * double(view.width) / double(view.height);
    return r;
}

} // namespace

bool brickReachable(const VczHeader& h, std::size_t b, const BrickView& view) {
    const std::array<Vec3, 8> corners = brickCorners(h, b, 1.0);
    for (const ClipPlane& cp : view.clipPlanes)
        if (std::all_of(corners.begin(), corners.end(),
                        [&](const Vec3& p) { return dot(cp.normal, p) + cp.offset < 0.0; }))
            return false; // clipped away: no sample the march keeps reads it
    const ProjectedRect r = project(corners, view);
    if (r.dmax <= 0) return false; // wholly behind the eye
    if (r.behind) return true;     // straddles the eye's plane: keep it
    return r.x1 >= -r.hw && r.x0 <= r.hw && r.y1 >= -r.hh && r.y0 <= r.hh;
}

double brickPixels(const VczHeader& h, std::size_t b, const BrickView& view) {
    const ProjectedRect r = project(brickCorners(h, b, 0.0), view);
    const double all = double(view.width) * double(view.height);
    if (r.dmax <= 0) return 0.0;
    if (r.behind) return all;
    const double w = std::max(0.0, std::min(r.x1, r.hw) - std::max(r.x0, -r.hw)),
                 hgt = std::max(0.0, std::min(r.y1, r.hh) - std::max(r.y0, -r.hh));
    return std::min(all, w * hgt / (4.0 * r.hw * r.hh) * all);
}

BrickSelection selectBricks(const VczHeader& h, const LodStatistics* stats, std::size_t frame, int maxLevel,
                            const TransferFunction& tf, const BrickView& view,
                            const std::vector<int>& forced) {
    const std::size_t nb = h.brickCount();
    BrickSelection s;
    s.level.assign(nb, 0);
    s.range.resize(nb);
    s.error.assign(nb, 0.0);
    std::vector<char> reach(nb, 0);
    for (std::size_t b = 0; b < nb; ++b) {
        reach[b] = brickReachable(h, b, view) ? 1 : 0;
        s.reachable += std::size_t(reach[b]);
        int level = 0;
        if (!forced.empty()) {
            level = forced[b];
        } else if (b < view.nonFinite.size() && view.nonFinite[b]) {
            level =
                0; // coarser levels hold the encoder's fill where NaN/Inf voxels are: only level 0 has them
        } else if (view.lod == LodMode::Auto && reach[b]) {
            for (int l = maxLevel; l > 0; --l)
                if (brickError(h, stats, frame, b, l, tf, view) <= view.lodError) {
                    level = l;
                    break;
                }
        }
        s.level[b] = level;
        s.range[b] = levelRange(h, stats, frame, b, level);
        s.error[b] = brickError(h, stats, frame, b, level, tf, view);
    }

    // Macrocells of the smallest brick edge; cell c covers voxels [c e, (c + 1) e] (closed, as the kernel's
    // skipping assumes). Its range is every brick it overlaps: a brick it meets only in that brick's low face
    // layer (the cell's upper face) adds its face range, the only values the cell's trilinear cells read
    // there.
    const Dims g = h.brickGrid();
    grid_detail::MacrocellGrid& m = s.macro;
    m.edge = unsigned(std::min({h.brick.x, h.brick.y, h.brick.z}));
    auto cells = [&](std::size_t n) {
        return unsigned(std::max<std::size_t>(1, (n - 1 + m.edge - 1) / m.edge));
    };
    m.nx = cells(h.dims.x);
    m.ny = cells(h.dims.y);
    m.nz = cells(h.dims.z);
    const std::size_t nc = std::size_t(m.nx) * m.ny * m.nz;
    m.min.assign(nc, std::numeric_limits<float>::infinity());
    m.max.assign(nc, -std::numeric_limits<float>::infinity());
    m.nonFinite.assign(nc, 0);
    std::vector<ValueRange> face(nb);
    for (std::size_t b = 0; b < nb; ++b)
        face[b] = faceRange(h, stats, frame, b, std::max(s.level[b], 0));
    s.standIn.resize(nb);
    for (std::size_t b = 0; b < nb; ++b)
        s.standIn[b] = float(face[b].min);
    // Along one axis: bricks over voxels [lo, hi]; `faceOnly` for a brick starting exactly at hi.
    struct Span {
        std::size_t b0, b1;
    };
    auto over = [](std::size_t lo, std::size_t hi, std::size_t brick, std::size_t n) {
        hi = std::min(hi, n - 1);
        return Span{lo / brick, hi / brick};
    };
    std::vector<std::vector<std::size_t>> cellBricks(nc);
    for (unsigned cz = 0; cz < m.nz; ++cz)
        for (unsigned cy = 0; cy < m.ny; ++cy)
            for (unsigned cx = 0; cx < m.nx; ++cx) {
                const std::size_t c = (std::size_t(cz) * m.ny + cy) * m.nx + cx;
                const std::size_t e = m.edge;
                const std::size_t hx = (cx + 1) * e, hy = (cy + 1) * e, hz = (cz + 1) * e;
                const Span sx = over(cx * e, hx, h.brick.x, h.dims.x),
                           sy = over(cy * e, hy, h.brick.y, h.dims.y),
                           sz = over(cz * e, hz, h.brick.z, h.dims.z);
                for (std::size_t bz = sz.b0; bz <= sz.b1; ++bz)
                    for (std::size_t by = sy.b0; by <= sy.b1; ++by)
                        for (std::size_t bx = sx.b0; bx <= sx.b1; ++bx) {
                            const std::size_t b = (bz * g.y + by) * g.x + bx;
                            const bool faceOnly =
                                bx * h.brick.x == hx || by * h.brick.y == hy || bz * h.brick.z == hz;
                            const ValueRange r = faceOnly ? face[b] : s.range[b];
                            cellBricks[c].push_back(b);
                            if (b < view.nonFinite.size() && view.nonFinite[b]) m.nonFinite[c] = 1;
                            m.min[c] = std::min(m.min[c], float(r.min));
                            m.max[c] = std::max(m.max[c], float(r.max));
                        }
            }
    s.empty =
        grid_detail::emptyMacrocells(m, tf, view.isoValues, view.isoOnly, view.tableNodes, view.nanVisible);
    // A reached brick is decoded when it takes part in a macrocell with something visible.
    std::vector<char> needed(nb, 0);
    for (std::size_t c = 0; c < nc; ++c)
        if (!s.empty[c])
            for (std::size_t b : cellBricks[c])
                needed[b] = 1;
    for (std::size_t b = 0; b < nb; ++b) {
        if (reach[b] && !needed[b]) ++s.hidden;
        if (!reach[b] || !needed[b]) s.level[b] = -1;
    }
    return s;
}

} // namespace volcl
