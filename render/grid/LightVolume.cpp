// Light-attenuation volumes: light grid geometry, the sweeps of each light, the device build and its C++ reference.
#include "render/grid/LightVolume.hpp"

#include "core/Error.hpp"
#include "core/runtime/Timing.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"
#include "render/grid/GridDetail.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace volcl {
namespace {

std::array<double, 3> arr(const float v[4]) {
    return {double(v[0]), double(v[1]), double(v[2])};
}

/// Voxel coordinates per light-grid coordinate on axis a.
double fromLight(const VolclGridParams& grid, const VolclLightVolumeParams& lv, int a) {
    return lv.dims[a] > 1 ? double(grid.dims[a] - 1) / double(lv.dims[a] - 1) : 0.0;
}

/// The light's position in light-grid coordinates (point lights).
Vec3 lightGridPosition(const SweptLight& light, const VolclGridParams& grid,
                       const VolclLightVolumeParams& lv) {
    Vec3 q{};
    for (int a = 0; a < 3; ++a)
        q[a] = (light.vector[a] - grid.origin[a]) / grid.spacing[a] * lv.toLight[a];
    return q;
}

/// Catmull-Rom weights at fraction f, in the kernel's float operations.
std::array<float, 4> catmullRom(float f) {
    const float f2 = f * f, f3 = f2 * f;
    return {0.5f * (-f3 + 2.0f * f2 - f), 0.5f * (3.0f * f3 - 5.0f * f2 + 2.0f),
            0.5f * (-3.0f * f3 + 4.0f * f2 + f), 0.5f * (f3 - f2)};
}

/// Bicubic (Catmull-Rom) in a w x h slice at (u, v), clamped, at least 0: the kernel's slice_cubic, with
/// the weights in float and the sum in double.
double sliceCubic(const std::vector<double>& s, unsigned w, unsigned h, double u, double v) {
    const int wi = int(w) - 1, hi = int(h) - 1;
    u = std::clamp(u, 0.0, double(wi));
    v = std::clamp(v, 0.0, double(hi));
    const int u0 = std::min(int(std::floor(u)), std::max(wi - 1, 0)),
              v0 = std::min(int(std::floor(v)), std::max(hi - 1, 0));
    const std::array<float, 4> wu = catmullRom(float(u - u0)), wv = catmullRom(float(v - v0));
    double sum = 0.0;
    for (int j = 0; j < 4; ++j) {
        const int y = std::clamp(v0 - 1 + j, 0, hi);
        double row = 0.0;
        for (int i = 0; i < 4; ++i)
            row += double(wu[std::size_t(i)]) *
                   s[std::size_t(y) * w + std::size_t(std::clamp(u0 - 1 + i, 0, wi))];
        sum += double(wv[std::size_t(j)]) * row;
    }
    return std::max(sum, 0.0);
}

/// Ray interval of o + t d inside the box [0, hi] intersected with [t0, t1] (cl/common/grid_sample.h's clip_box).
std::array<double, 2> clipBox(const Vec3& o, const Vec3& d, const Vec3& hi, double t0, double t1) {
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0.0) {
            if (o[a] < 0.0 || o[a] > hi[a]) return {1.0, 0.0};
        } else {
            const double ta = (0.0 - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
            t0 = std::max(t0, std::min(ta, tb));
            t1 = std::min(t1, std::max(ta, tb));
        }
    }
    return {t0, t1};
}

/// |light - node| per axis in world units, in the kernel's float operations (light_volume.cl).
std::array<float, 3> floatDistances(const SweptLight& light, const VolclGridParams& grid, const Vec3& node,
                                    const Vec3& from) {
    std::array<float, 3> w{};
    for (int k = 0; k < 3; ++k) {
        const float p = float(node[k]) * float(from[k]);
        const float q = (float(light.vector[k]) - grid.origin[k]) * grid.invSpacing[k] - p;
        w[k] = std::abs(q * grid.spacing[k]);
    }
    return w;
}

} // namespace

std::vector<SweptLight> sweptLights(const VolclLightingParams& lighting, const Camera& camera) {
    std::vector<SweptLight> out;
    for (unsigned i = 0; i < lighting.lightCount; ++i) {
        const float kind = lighting.lightPos[i][3];
        SweptLight l;
        if (kind == VOLCL_LIGHT_HEAD) {
            l.head = true;
            l.point = camera.projection == Projection::Perspective;
            l.vector = l.point ? camera.eye : normalized(sub(camera.eye, camera.target));
        } else {
            l.point = kind == VOLCL_LIGHT_POINT;
            l.vector = arr(lighting.lightPos[i]);
        }
        out.push_back(l);
    }
    return out;
}

VolclLightVolumeParams lightVolumeGeometry(const std::array<std::size_t, 3>& voxels, int cell,
                                           std::size_t lights) {
    if (cell < 1) throw UsageError("light volume cell must be >= 1 voxel");
    VolclLightVolumeParams p{};
    std::size_t nodes = 1;
    for (int a = 0; a < 3; ++a) {
        const std::size_t n = voxels[a];
        const std::size_t m = n > 1 ? (n - 2) / std::size_t(cell) + 2 : 1; // ceil((n - 1) / cell) + 1
        p.dims[a] = volcl_uint(m);
        p.toLight[a] = n > 1 ? float(double(m - 1) / double(n - 1)) : 0.0f;
        nodes *= m;
    }
    if (nodes * std::max<std::size_t>(lights, 1) >= (std::size_t(1) << 32))
        throw DataError("light volume of " + std::to_string(nodes) +
                        " nodes per light is too large (use a larger "
                        "effects.light_volume_cell)");
    p.dims[3] = volcl_uint(nodes);
    return p;
}

std::vector<LightSweep> lightSweeps(const SweptLight& light, const VolclGridParams& grid,
                                    const VolclLightVolumeParams& lv) {
    std::vector<LightSweep> out;
    if (!light.point) {
        // The axis crossing the most light cells per unit length: the shortest steps between slices.
        int axis = -1;
        double best = -1.0;
        for (int a = 0; a < 3; ++a) {
            if (lv.dims[a] < 2) continue;
            const double perCell = std::abs(light.vector[a]) / (grid.spacing[a] * fromLight(grid, lv, a));
            if (perCell > best) {
                best = perCell;
                axis = a;
            }
        }
        if (axis < 0) axis = 0; // a single node: one slice of one node
        LightSweep s;
        s.axis = unsigned(axis);
        s.dir = light.vector[axis] > 0.0 ? -1 : 1; // toward the light: higher slices when it lies that way
        const int m = int(lv.dims[axis]);
        s.first = s.dir > 0 ? 0 : m - 1;
        s.last = s.dir > 0 ? m - 1 : 0;
        out.push_back(s);
        return out;
    }
    const Vec3 q = lightGridPosition(light, grid, lv);
    for (int a = 0; a < 3; ++a) {
        const int m = int(lv.dims[a]);
        // Slices on each side of the light's plane, swept outward from it (the plane itself on both sides).
        const double up = std::ceil(q[a]), down = std::floor(q[a]);
        if (up <= double(m - 1)) out.push_back({unsigned(a), 1, int(std::max(up, 0.0)), m - 1, true});
        if (down >= 0.0) out.push_back({unsigned(a), -1, int(std::min(down, double(m - 1))), 0, true});
    }
    return out;
}

std::vector<double> lightVolumeReference(const std::vector<float>& values, const VolclGridParams& grid,
                                         const TransferFunction& tf, const std::vector<SweptLight>& lights,
                                         int cell, double step) {
    const std::array<std::size_t, 3> n{grid.dims[0], grid.dims[1], grid.dims[2]};
    const VolclLightVolumeParams lv = lightVolumeGeometry(n, cell, lights.size());
    const Vec3 sp = arr(grid.spacing), origin = arr(grid.origin);
    const Vec3 hi{double(n[0] - 1), double(n[1] - 1), double(n[2] - 1)};
    const Vec3 from{fromLight(grid, lv, 0), fromLight(grid, lv, 1), fromLight(grid, lv, 2)};
    float margin = 0.0f; // in float, as the device's
    for (int a = 0; a < 3; ++a)
        margin = std::max(margin, 2.0f * float(from[a]) * grid.spacing[a]);
    std::vector<double> out(std::size_t(lv.dims[3]) * lights.size(), 0.0);
    for (std::size_t li = 0; li < lights.size(); ++li) {
        const SweptLight& light = lights[li];
        for (const LightSweep& sw : lightSweeps(light, grid, lv)) {
            const unsigned a = sw.axis, b = (a + 1) % 3, c = (a + 2) % 3;
            const unsigned mb = lv.dims[b], mc = lv.dims[c];
            std::vector<double> prev(std::size_t(mb) * mc, 0.0), cur(prev.size(), 0.0);
            for (int s = sw.first;; s += sw.dir) {
                for (unsigned v = 0; v < mc; ++v)
                    for (unsigned u = 0; u < mb; ++u) {
                        Vec3 node{};
                        node[a] = s;
                        node[b] = u;
                        node[c] = v;
                        const Vec3 p = mul(node, from);
                        Vec3 d;
                        double dist = std::numeric_limits<double>::infinity();
                        bool store = true;
                        double& out1 = cur[std::size_t(v) * mb + u];
                        if (light.point) {
                            Vec3 q{};
                            for (int k = 0; k < 3; ++k)
                                q[k] = (light.vector[k] - origin[k]) / sp[k] - p[k];
                            const Vec3 qw = mul(q, sp);
                            dist = norm(qw);
                            d = dist > 0.0 ? scale(q, 1.0 / dist) : Vec3{0, 0, 0};
                            // Which pyramid a node belongs to decides between two approximations: decided
                            // in float, as the kernel decides (ties are common on regular grids).
                            const std::array<float, 3> w = floatDistances(light, grid, node, from);
                            if (w[b] > w[a] + margin || w[c] > w[a] + margin) {
                                out1 = 0.0;
                                continue;
                            }
                            unsigned own = 0;
                            for (unsigned k = 1; k < 3; ++k)
                                if (w[k] > w[own]) own = k;
                            store = own == a;
                        } else {
                            for (int k = 0; k < 3; ++k)
                                d[k] = light.vector[k] / sp[k];
                        }
                        const auto span = clipBox(p, d, hi, 0.0, dist);
                        double tEnd = span[1] > span[0] ? std::max(span[1], 0.0) : 0.0;
                        double depth = 0.0;
                        if (s != sw.first && d[a] != 0.0) {
                            const double tPrev = (double(s - sw.dir) * from[a] - p[a]) / d[a];
                            if (tPrev > 0.0 && tPrev <= tEnd + 1e-4 * tPrev) {
                                tEnd = tPrev;
                                const Vec3 x = add(p, scale(d, tPrev));
                                depth = sliceCubic(prev, mb, mc, x[b] * lv.toLight[b], x[c] * lv.toLight[c]);
                            }
                        }
                        if (tEnd > 0.0) {
                            const long steps = std::max(1L, long(std::ceil(tEnd / step)));
                            const double h = tEnd / double(steps);
                            for (long k = 0; k < steps; ++k)
                                depth += tf.extinctionAt(grid_detail::trilinear(
                                             values, n, add(p, scale(d, (double(k) + 0.5) * h)))) *
                                         h;
                        }
                        out1 = depth;
                        if (store) {
                            const std::size_t i = std::size_t(node[0]), j = std::size_t(node[1]),
                                              k = std::size_t(node[2]);
                            out[li * lv.dims[3] + (k * lv.dims[1] + j) * lv.dims[0] + i] = out1;
                        }
                    }
                std::swap(prev, cur);
                if (s == sw.last) break;
            }
        }
    }
    return out;
}

bool LightVolume::current(const Inputs& in) const {
    if (!valid_ || in.voxels != built_.voxels || in.knots != built_.knots ||
        in.knotCount != built_.knotCount || !(in.defines == built_.defines) || in.source != built_.source ||
        in.cell != built_.cell || in.step != built_.step || in.fieldKey != built_.fieldKey ||
        in.lights.size() != built_.lights.size())
        return false;
    for (int a = 0; a < 3; ++a)
        if (in.grid.dims[a] != built_.grid.dims[a] || in.grid.spacing[a] != built_.grid.spacing[a] ||
            in.grid.origin[a] != built_.grid.origin[a])
            return false;
    const double tolerance = in.headToleranceDeg * std::numbers::pi / 180.0;
    for (std::size_t i = 0; i < in.lights.size(); ++i) {
        const SweptLight &now = in.lights[i], &then = built_.lights[i];
        if (now == then) continue;
        if (!now.head || !then.head || now.point != then.point) return false;
        // A head light that turned less than the tolerance, seen from the volume's centre, keeps its volume.
        const Vec3 u = now.point ? sub(now.vector, in.centre) : now.vector;
        const Vec3 w = then.point ? sub(then.vector, in.centre) : then.vector;
        const double nu = norm(u), nw = norm(w);
        if (!(nu > 0.0 && nw > 0.0)) return false;
        const double angle = std::acos(std::clamp(dot(u, w) / (nu * nw), -1.0, 1.0));
        if (!(angle <= tolerance)) return false;
        if (now.point && std::abs(nu - nw) > std::tan(tolerance) * nw) return false; // moved nearer or away
    }
    return true;
}

bool LightVolume::update(ComputeContext& cc, const Inputs& in) {
    if (current(in)) return false;
    build(cc, in);
    return true;
}

const DeviceBuffer<float>& LightVolume::buffer(ComputeContext& cc) {
    if (volume_.size() == 0) volume_ = cc.upload(std::vector<float>{0.0f}, CL_MEM_READ_WRITE);
    return volume_;
}

void LightVolume::build(ComputeContext& cc, const Inputs& in) {
    Stopwatch sw;
    const std::array<std::size_t, 3> n{in.grid.dims[0], in.grid.dims[1], in.grid.dims[2]};
    const std::size_t lights = std::max<std::size_t>(in.lights.size(), 1);
    params_ = lightVolumeGeometry(n, in.cell, lights);
    const std::size_t total = std::size_t(params_.dims[3]) * lights;
    if (volume_.size() != total) volume_ = cc.allocate<float>(total);
    std::size_t slice = 1;
    for (int a = 0; a < 3; ++a)
        slice = std::max(slice, std::size_t(params_.dims[(a + 1) % 3]) * params_.dims[(a + 2) % 3]);
    // Nodes no sweep stores (none, unless a point light's pyramids leave one out by rounding) read as lit.
    cc.queue().enqueueFillBuffer(volume_.get(), 0.0f, 0, total * sizeof(float));
    if (sliceA_.size() < slice) {
        sliceA_ = cc.allocate<float>(slice);
        sliceB_ = cc.allocate<float>(slice);
    }
    cl::Kernel k = cc.kernel(in.source, "light_volume_slice", in.defines);
    VolclLightSweepParams S{};
    S.grid = in.grid;
    S.lv = params_;
    for (int a = 0; a < 3; ++a)
        S.fromLight[a] = float(fromLight(in.grid, params_, a));
    float margin = 0.0f;
    for (int a = 0; a < 3; ++a)
        margin = std::max(margin, 2.0f * S.fromLight[a] * in.grid.spacing[a]);
    S.margin = margin;
    S.step = float(in.step);
    S.knotCount = volcl_uint(in.knotCount);
    for (std::size_t li = 0; li < in.lights.size(); ++li) {
        const SweptLight& light = in.lights[li];
        for (int a = 0; a < 3; ++a)
            S.light[a] = float(light.vector[a]);
        S.light[3] = light.point ? VOLCL_LIGHT_POINT : VOLCL_LIGHT_DIRECTIONAL;
        S.lightOffset = volcl_uint(li * params_.dims[3]);
        for (const LightSweep& sweep : lightSweeps(light, in.grid, params_)) {
            S.axis = sweep.axis;
            S.dir = sweep.dir;
            S.first = volcl_uint(sweep.first);
            S.cone = sweep.cone ? 1u : 0u;
            const std::size_t mb = params_.dims[(sweep.axis + 1) % 3],
                              mc = params_.dims[(sweep.axis + 2) % 3];
            const cl::Buffer *prev = &sliceA_.get(), *cur = &sliceB_.get();
            for (int s = sweep.first;; s += sweep.dir) {
                S.slice = volcl_uint(s);
                setArgs(k, *in.voxels, *in.knots, S, *prev, *cur, volume_);
                cc.launch2d(k, mb, mc);
                std::swap(prev, cur);
                if (s == sweep.last) break;
            }
        }
    }
    cc.finish();
    built_ = in;
    valid_ = true;
    buildMs_ = sw.milliseconds();
    ++builds_;
}

} // namespace volcl
