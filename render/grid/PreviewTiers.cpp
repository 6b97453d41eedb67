// Shear-warp factorisation, run-length encoding, TF tables, and the C++ references of the preview kernels.
#include "render/grid/PreviewTiers.hpp"

#include "core/Error.hpp"
#include "render/Reference.hpp"
#include "render/VecMath.hpp"
#include "render/grid/GridDetail.hpp"
#include "render/grid/GridRenderer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl::preview {
namespace {

/// The volume's range widened to a unit range when constant, so the tables have a positive scale.
ValueRange tableRange(const ValueRange& r) {
    return {r.min, r.max > r.min ? r.max : r.min + 1.0};
}

/// Linear interpolation of a node table at data value s (clamped to the nodes), as the kernels do.
std::array<double, 4> lookup(const std::vector<cl_float4>& table, std::size_t first,
                             const VolclPreviewTable& g, double s) {
    const double x = std::clamp((s - double(g.lo)) * double(g.scale), 0.0, double(g.size - 1));
    const std::size_t i = std::min<std::size_t>(std::size_t(x), g.size - 2);
    const double f = x - double(i);
    std::array<double, 4> out{};
    for (int ch = 0; ch < 4; ++ch) {
        const double lo = table[first + i].s[ch], hi = table[first + i + 1].s[ch];
        out[ch] = lo + f * (hi - lo);
    }
    return out;
}

/// The camera a scene renders with: its own, else the default framing of the grid.
Camera sceneCamera(const Volume& volume, const Scene& scene) {
    return scene.camera ? *scene.camera : defaultCamera(volume);
}

/// A world ray in voxel coordinates (origin and direction per world unit), as grid_ray() in the kernels.
std::array<Vec3, 2> voxelRay(const Volume& volume, const CameraRay& ray) {
    Vec3 o{}, d{};
    for (int i = 0; i < 3; ++i) {
        o[i] = (ray.origin[i] - volume.origin[i]) / volume.spacing[i];
        d[i] = ray.direction[i] / volume.spacing[i];
    }
    return {o, d};
}

std::size_t dimAlong(const Dims& d, int axis) {
    return axis == 0 ? d.x : axis == 1 ? d.y : d.z;
}

} // namespace

ShearWarpFactors shearWarpFactors(const Volume& volume, const Camera& camera) {
    if (camera.projection != Projection::Orthographic)
        throw UsageError("render.method shear-warp: orthographic cameras only (volcl factorises parallel "
                         "projections); use drc or raymarch for a perspective view");
    const Vec3 f = normalized(sub(camera.target, camera.eye));
    Vec3 dI{};
    for (int i = 0; i < 3; ++i)
        dI[i] = f[i] / volume.spacing[i];
    ShearWarpFactors s;
    s.c = 0;
    for (int i = 1; i < 3; ++i)
        if (std::abs(dI[i]) > std::abs(dI[s.c])) s.c = i;
    s.a = s.c == 0 ? 1 : 0;
    s.b = s.c == 2 ? 1 : 2;
    s.frontAtZero = dI[s.c] > 0.0;
    const Dims& d = volume.dims();
    s.nc = int(dimAlong(d, s.c));
    s.na = int(dimAlong(d, s.a));
    s.nb = int(dimAlong(d, s.b));
    s.shearA = -dI[s.a] / dI[s.c];
    s.shearB = -dI[s.b] / dI[s.c];
    const double depth = double(s.nc - 1);
    s.offA = s.shearA < 0.0 ? -s.shearA * depth : 0.0;
    s.offB = s.shearB < 0.0 ? -s.shearB * depth : 0.0;
    s.width = int(std::ceil(double(s.na - 1) + std::abs(s.shearA) * depth)) + 1;
    s.height = int(std::ceil(double(s.nb - 1) + std::abs(s.shearB) * depth)) + 1;
    s.sliceDistance = volume.spacing[s.c] / std::abs(f[s.c]);
    return s;
}

VolclShearWarpParams shearWarpParams(const ShearWarpFactors& f, const VolclPreviewTable& table) {
    VolclShearWarpParams p{};
    p.axis[0] = volcl_uint(f.c);
    p.axis[1] = volcl_uint(f.a);
    p.axis[2] = volcl_uint(f.b);
    p.axis[3] = f.frontAtZero ? 1u : 0u;
    p.dims[0] = volcl_uint(f.nc);
    p.dims[1] = volcl_uint(f.na);
    p.dims[2] = volcl_uint(f.nb);
    p.inter[0] = volcl_uint(f.width);
    p.inter[1] = volcl_uint(f.height);
    p.shear[0] = float(f.shearA);
    p.shear[1] = float(f.shearB);
    p.shear[2] = float(f.offA);
    p.shear[3] = float(f.offB);
    p.table = table;
    return p;
}

OpacityBins::OpacityBins(const TransferFunction& tf, const ValueRange& range, int bins) {
    const ValueRange r = tableRange(range);
    lo_ = r.min;
    scale_ = double(bins) / (r.max - r.min);
    prefix_.assign(std::size_t(bins) + 1, 0);
    const double w = (r.max - r.min) / double(bins);
    for (int i = 0; i < bins; ++i) {
        const bool on =
            grid_detail::maxExtinctionOver(tf, lo_ + double(i) * w, lo_ + double(i + 1) * w) > 0.0;
        prefix_[std::size_t(i) + 1] = prefix_[std::size_t(i)] + (on ? 1 : 0);
    }
}

bool OpacityBins::visible(double lo, double hi) const {
    const double last = double(prefix_.size() - 2);
    const std::size_t i0 = std::size_t(std::clamp(std::floor((lo - lo_) * scale_), 0.0, last));
    const std::size_t i1 = std::size_t(std::clamp(std::floor((hi - lo_) * scale_), 0.0, last));
    return prefix_[i1 + 1] > prefix_[i0];
}

RunEncoding encodeRuns(const std::vector<float>& values, const Dims& dims, int c, const OpacityBins& bins) {
    const int a = c == 0 ? 1 : 0, b = c == 2 ? 1 : 2;
    const std::size_t stride[3] = {1, dims.x, dims.x * dims.y};
    const std::size_t nc = dimAlong(dims, c), na = dimAlong(dims, a), nb = dimAlong(dims, b);
    RunEncoding e;
    e.c = c;
    const std::size_t rows = nb > 1 ? nc * (nb - 1) : 0;
    e.rowRuns.assign(rows + 1, 0);
    if (na < 2 || nb < 2) return e;
    std::vector<float> r0(na), r1(na);
    const auto loadRow = [&](std::vector<float>& dst, std::size_t k, std::size_t j) {
        const std::size_t base = k * stride[c] + j * stride[b];
        for (std::size_t i = 0; i < na; ++i)
            dst[i] = values[base + i * stride[a]];
    };
    for (std::size_t k = 0; k < nc; ++k)
        for (std::size_t j = 0; j + 1 < nb; ++j) {
            loadRow(r0, k, j);
            loadRow(r1, k, j + 1);
            std::size_t i = 0;
            while (i + 1 < na) {
                const auto cellVisible = [&](std::size_t x) {
                    const float lo = std::min({r0[x], r0[x + 1], r1[x], r1[x + 1]});
                    const float hi = std::max({r0[x], r0[x + 1], r1[x], r1[x + 1]});
                    return bins.visible(lo, hi);
                };
                if (!cellVisible(i)) {
                    ++i;
                    continue;
                }
                const std::size_t first = i;
                while (i + 1 < na && cellVisible(i))
                    ++i;
                const std::size_t n = i - first;
                e.runs.push_back({{cl_uint(first), cl_uint(n), cl_uint(e.data.size()), 0u}});
                e.data.insert(e.data.end(), r0.begin() + std::ptrdiff_t(first),
                              r0.begin() + std::ptrdiff_t(first + n + 1));
                e.data.insert(e.data.end(), r1.begin() + std::ptrdiff_t(first),
                              r1.begin() + std::ptrdiff_t(first + n + 1));
                e.visibleCells += n;
            }
            e.cells += na - 1;
            e.rowRuns[k * (nb - 1) + j + 1] = cl_uint(e.runs.size());
        }
    if (e.data.size() >= std::numeric_limits<cl_uint>::max())
        throw DataError("shear-warp: the classified volume holds more than 2^32 values");
    return e;
}

std::vector<cl_float4> straightTable(const TransferFunction& tf, const ValueRange& range) {
    const ValueRange r = tableRange(range);
    std::vector<cl_float4> t(kTableNodes);
    for (int i = 0; i < kTableNodes; ++i) {
        const double s = r.min + (r.max - r.min) * double(i) / double(kTableNodes - 1);
        const std::array<double, 3> c = tf.colorAt(s);
        t[std::size_t(i)] = {{float(c[0]), float(c[1]), float(c[2]), float(tf.extinctionAt(s))}};
    }
    return t;
}

VolclPreviewTable tableGeometry(const ValueRange& range, double earlyTermination) {
    const ValueRange r = tableRange(range);
    VolclPreviewTable g{};
    g.lo = float(r.min);
    g.scale = float(double(kTableNodes - 1) / (r.max - r.min));
    g.earlyTermination = float(earlyTermination);
    g.size = kTableNodes;
    return g;
}

std::vector<cl_float4> slabTables(const std::vector<cl_float4>& straight, double distance) {
    std::vector<cl_float4> out(2 * straight.size());
    for (int half = 0; half < 2; ++half)
        for (std::size_t i = 0; i < straight.size(); ++i) {
            const cl_float4& e = straight[i];
            const double alpha = 1.0 - std::exp(-double(e.s[3]) * distance * (half ? 0.5 : 1.0));
            out[std::size_t(half) * straight.size() + i] = {
                {float(e.s[0] * alpha), float(e.s[1] * alpha), float(e.s[2] * alpha), float(alpha)}};
        }
    return out;
}

ImageBuffer shearWarpReference(const Volume& volume, const TransferFunction& tf, const Scene& scene) {
    const Camera camera = sceneCamera(volume, scene);
    const ShearWarpFactors f = shearWarpFactors(volume, camera);
    const ValueRange range = grid_detail::valueRange(volume);
    const std::vector<float> values = volume.toFloat();
    const RunEncoding enc = encodeRuns(values, volume.dims(), f.c, OpacityBins(tf, range));
    const VolclPreviewTable g = tableGeometry(range, scene.earlyTermination);
    const std::vector<cl_float4> tables = slabTables(straightTable(tf, range), f.sliceDistance);
    const std::size_t W = std::size_t(f.width), H = std::size_t(f.height);
    std::vector<std::array<double, 4>> inter(W * H, {0, 0, 0, 0});
    if (f.nc >= 2 && f.na >= 2 && f.nb >= 2)
        for (int kk = 0; kk < f.nc; ++kk) {
            const int k = f.frontAtZero ? kk : f.nc - 1 - kk;
            const std::size_t table = (k == 0 || k == f.nc - 1) ? g.size : 0;
            const double shiftA = f.offA + f.shearA * k;
            for (std::size_t v = 0; v < H; ++v) {
                const double bf = double(v) - f.offB - f.shearB * k;
                if (!(bf >= 0.0 && bf <= double(f.nb - 1))) continue;
                const std::size_t j = std::min(std::size_t(bf), std::size_t(f.nb - 2));
                const double fy = bf - double(j);
                const std::size_t row = std::size_t(k) * std::size_t(f.nb - 1) + j;
                for (std::size_t r = enc.rowRuns[row]; r < enc.rowRuns[row + 1]; ++r) {
                    const cl_uint4 run = enc.runs[r];
                    const double first = double(run.s[0]) + shiftA;
                    const long uLast = std::min(long(std::floor(first + run.s[1])), long(W) - 1);
                    for (long u = std::max(long(std::ceil(first)), 0L); u <= uLast; ++u) {
                        std::array<double, 4>& px = inter[v * W + std::size_t(u)];
                        if (px[3] >= scene.earlyTermination) continue;
                        const double ia = std::clamp(double(u) - first, 0.0, double(run.s[1]));
                        const std::size_t x = std::min<std::size_t>(std::size_t(ia), run.s[1] - 1);
                        const double fx = ia - double(x);
                        const float* row0 = enc.data.data() + run.s[2];
                        const float* row1 = row0 + run.s[1] + 1;
                        const double s0 = row0[x] + fx * (double(row0[x + 1]) - row0[x]);
                        const double s1 = row1[x] + fx * (double(row1[x + 1]) - row1[x]);
                        const std::array<double, 4> e = lookup(tables, table, g, s0 + fy * (s1 - s0));
                        for (int ch = 0; ch < 4; ++ch)
                            px[ch] += (1.0 - px[3]) * e[ch];
                    }
                }
            }
        }
    return traceReferenceImage(scene, camera, false, 0, [&](const CameraRay& ray) {
        const auto [o, d] = voxelRay(volume, ray);
        const double t = -o[f.c] / d[f.c];
        const double pa = std::clamp(o[f.a] + t * d[f.a] + f.offA, -2.0, double(W) + 1.0);
        const double pb = std::clamp(o[f.b] + t * d[f.b] + f.offB, -2.0, double(H) + 1.0);
        const double fa = std::floor(pa), fb = std::floor(pb);
        ReferencePixel px = emptyReferencePixel();
        for (int db = 0; db < 2; ++db)
            for (int da = 0; da < 2; ++da) {
                const long ua = long(fa) + da, vb = long(fb) + db;
                if (ua < 0 || vb < 0 || ua >= long(W) || vb >= long(H)) continue;
                const double w = (da ? pa - fa : 1.0 - (pa - fa)) * (db ? pb - fb : 1.0 - (pb - fb));
                for (int ch = 0; ch < 4; ++ch)
                    px[std::size_t(ch)] += w * inter[std::size_t(vb) * W + std::size_t(ua)][std::size_t(ch)];
            }
        return px;
    });
}

ImageBuffer discreteRayCastReference(const Volume& volume, const TransferFunction& tf, const Scene& scene) {
    const Camera camera = sceneCamera(volume, scene);
    const ValueRange range = grid_detail::valueRange(volume);
    const VolclPreviewTable g = tableGeometry(range, scene.earlyTermination);
    const std::vector<cl_float4> table = straightTable(tf, range);
    const Dims& dims = volume.dims();
    const long n[3] = {long(dims.x), long(dims.y), long(dims.z)};
    return traceReferenceImage(scene, camera, false, 0, [&](const CameraRay& ray) {
        const auto [o, d] = voxelRay(volume, ray);
        // The ray's interval inside the box [0, n - 1] (voxel coordinates), t the world distance.
        double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
        for (int a = 0; a < 3; ++a) {
            const double hi = double(n[a] - 1);
            if (d[a] == 0.0) {
                if (o[a] < 0.0 || o[a] > hi) return emptyReferencePixel();
                continue;
            }
            const double ta = -o[a] / d[a], tb = (hi - o[a]) / d[a];
            t0 = std::max(t0, std::min(ta, tb));
            t1 = std::min(t1, std::max(ta, tb));
        }
        ReferencePixel px = emptyReferencePixel();
        if (!(t1 > t0)) return px;
        long idx[3];
        int step[3];
        double tNext[3], tDelta[3];
        for (int a = 0; a < 3; ++a) {
            const double e = o[a] + t0 * d[a] + (d[a] > 0.0 ? 1e-4 : d[a] < 0.0 ? -1e-4 : 0.0);
            idx[a] = std::clamp(long(std::floor(e + 0.5)), 0L, n[a] - 1);
            step[a] = d[a] > 0.0 ? 1 : -1;
            tDelta[a] = d[a] != 0.0 ? 1.0 / std::abs(d[a]) : std::numeric_limits<double>::infinity();
            tNext[a] = d[a] != 0.0 ? (double(idx[a]) + 0.5 * step[a] - o[a]) / d[a]
                                   : std::numeric_limits<double>::infinity();
        }
        double T = 1.0, t = t0;
        while (t < t1) {
            const int a =
                tNext[0] <= tNext[1] ? (tNext[0] <= tNext[2] ? 0 : 2) : (tNext[1] <= tNext[2] ? 1 : 2);
            const double tEnd = std::min(tNext[a], t1);
            const std::size_t at =
                std::size_t(idx[2]) * dims.x * dims.y + std::size_t(idx[1]) * dims.x + std::size_t(idx[0]);
            const std::array<double, 4> e = lookup(table, 0, g, volume.valueAt(at));
            const double alpha = 1.0 - std::exp(-e[3] * (tEnd - t));
            for (int ch = 0; ch < 3; ++ch)
                px[std::size_t(ch)] += T * alpha * e[std::size_t(ch)];
            T *= 1.0 - alpha;
            if (1.0 - T >= scene.earlyTermination) break;
            t = tEnd;
            idx[a] += step[a];
            if (idx[a] < 0 || idx[a] >= n[a]) break;
            tNext[a] += tDelta[a];
        }
        px[3] = 1.0 - T;
        return px;
    });
}

} // namespace volcl::preview
