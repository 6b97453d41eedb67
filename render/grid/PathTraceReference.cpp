// The grid path tracer's double-precision reference: cl/render/pathtrace.cl step for step (delta and ratio tracking
// on the same majorant grid, Henyey-Greenstein, next-event estimation) with the same random stream.
#include "cl/common/counter_rng.h"
#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "core/runtime/DeviceProfile.hpp"
#include "core/runtime/ParallelFor.hpp"
#include "render/Reference.hpp"
#include "render/VecMath.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/grid/PathTracer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace volcl {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double uniform(VolclRng& r) {
    return double(volcl_rng_next24(&r)) * (1.0 / 16777216.0);
}

double phaseHG(double g, double ct) {
    const double denom = 1.0 + g * g - 2.0 * g * ct;
    return (1.0 - g * g) / (4.0 * std::numbers::pi * denom * std::sqrt(denom));
}

Vec3 samplePhase(const Vec3& dir, double g, double u1, double u2) {
    double ct;
    if (std::abs(g) < 1e-3) {
        ct = 1.0 - 2.0 * u1;
    } else {
        const double sq = (1.0 - g * g) / (1.0 - g + 2.0 * g * u1);
        ct = (1.0 + g * g - sq * sq) / (2.0 * g);
    }
    ct = std::clamp(ct, -1.0, 1.0);
    const double st = std::sqrt(std::max(0.0, 1.0 - ct * ct)), phi = 2.0 * std::numbers::pi * u2;
    const double sgn = dir[2] >= 0.0 ? 1.0 : -1.0;
    const double a = -1.0 / (sgn + dir[2]), b = dir[0] * dir[1] * a;
    const Vec3 t1{1.0 + sgn * dir[0] * dir[0] * a, sgn * b, -sgn * dir[0]};
    const Vec3 t2{b, sgn + dir[1] * dir[1] * a, -dir[1]};
    return normalized(add(add(scale(t1, st * std::cos(phi)), scale(t2, st * std::sin(phi))), scale(dir, ct)));
}

class PathReference {
public:
    PathReference(const Volume& v, const TransferFunction& tf, const Scene& s)
        : vol_(v), tf_(tf), fx_(s.effects), values_(v.toFloat()),
          cam_(s.camera ? *s.camera : defaultCamera(v)), lighting_(s, cam_),
          macro_(grid_detail::buildMacrocells(v, genericDeviceProfile().rayMarch.macrocellEdge)),
          majorant_(majorantGrid(macro_, tf)) {
        const Dims& d = v.dims();
        n_ = {d.x, d.y, d.z};
        for (const auto& l : s.lights)
            if (l.intensity > 0.0 && lights_.size() < VOLCL_MAX_LIGHTS) lights_.push_back(l);
    }
    const Camera& camera() const noexcept { return cam_; }

    /// One path through the pixel's ray: (r, g, b, 1 - primary transmittance).
    std::array<double, 4> sample(const CameraRay& ray, VolclRng& rng) const {
        const Vec3 o0 = toVoxel(ray.origin), d0 = divide(ray.direction);
        double t0 = 0.0, t1 = kInf;
        if (!clipBox(o0, d0, t0, t1)) return {0, 0, 0, 0};
        const bool sky = fx_.environment[0] > 0.0 || fx_.environment[1] > 0.0 || fx_.environment[2] > 0.0;
        const double g = fx_.phaseG;
        const double Tp = transmittance(o0, d0, t0, t1, rng);
        Vec3 L{0, 0, 0}, beta{1, 1, 1};
        Vec3 o = o0, d = d0, dW = ray.direction;
        for (int k = 1;; ++k) {
            double tau;
            Vec3 c;
            const double t = deltaTrack(o, d, t0, t1, rng, tau, c);
            if (!(t < kInf)) break;
            const Vec3 pv = add(o, scale(d, t)), xw = toWorld(pv);
            if (fx_.emission) L = add(L, mul(beta, c));
            Vec3 a;
            for (int ch = 0; ch < 3; ++ch)
                a[ch] = std::clamp(fx_.albedo * c[ch], 0.0, 1.0);
            if (!(a[0] > 0.0 || a[1] > 0.0 || a[2] > 0.0)) break;
            for (const Light& l : lights_) {
                double dist;
                const Vec3 Ld = lighting_.lightDir(l, ray, xw, dist);
                const Vec3 dv = divide(Ld);
                double s0 = 0.0, s1 = dist;
                const double Tr = clipBox(pv, dv, s0, s1) ? transmittance(pv, dv, s0, s1, rng) : 1.0;
                L = add(L,
                        scale(mul(mul(beta, a), scale(l.color, l.intensity)), phaseHG(g, dot(Ld, dW)) * Tr));
            }
            if (sky) {
                const double u1 = uniform(rng), u2 = uniform(rng);
                const Vec3 wv = divide(samplePhase(dW, g, u1, u2));
                double s0 = 0.0, s1 = kInf;
                const double Tr = clipBox(pv, wv, s0, s1) ? transmittance(pv, wv, s0, s1, rng) : 1.0;
                L = add(L, scale(mul(mul(beta, a), fx_.environment), Tr));
            }
            if (k >= fx_.maxBounces) break;
            beta = mul(beta, a);
            if (k >= 3) {
                const double q = std::min(std::max({beta[0], beta[1], beta[2]}), 1.0);
                if (uniform(rng) >= q) break;
                beta = scale(beta, 1.0 / q);
            }
            const double u1 = uniform(rng), u2 = uniform(rng);
            dW = samplePhase(dW, g, u1, u2);
            o = pv;
            d = divide(dW);
            t0 = 0.0;
            t1 = kInf;
            if (!clipBox(o, d, t0, t1)) break;
        }
        return {L[0], L[1], L[2], 1.0 - Tp};
    }

private:
    Vec3 toVoxel(const Vec3& w) const {
        return {(w[0] - vol_.origin[0]) / vol_.spacing[0], (w[1] - vol_.origin[1]) / vol_.spacing[1],
                (w[2] - vol_.origin[2]) / vol_.spacing[2]};
    }
    Vec3 toWorld(const Vec3& p) const {
        return {vol_.origin[0] + p[0] * vol_.spacing[0], vol_.origin[1] + p[1] * vol_.spacing[1],
                vol_.origin[2] + p[2] * vol_.spacing[2]};
    }
    Vec3 divide(const Vec3& w) const {
        return {w[0] / vol_.spacing[0], w[1] / vol_.spacing[1], w[2] / vol_.spacing[2]};
    }
    /// The ray's interval inside the box, intersected with [t0, t1]; false when empty.
    bool clipBox(const Vec3& o, const Vec3& d, double& t0, double& t1) const {
        for (int a = 0; a < 3; ++a) {
            const double hi = double(n_[a] - 1);
            if (d[a] == 0.0) {
                if (o[a] < 0.0 || o[a] > hi) return false;
            } else {
                const double u = (0.0 - o[a]) / d[a], v = (hi - o[a]) / d[a];
                t0 = std::max(t0, std::min(u, v));
                t1 = std::min(t1, std::max(u, v));
            }
        }
        return t1 > t0;
    }
    double voxel(std::size_t i, std::size_t j, std::size_t k) const { return values_[vol_.index(i, j, k)]; }
    double field(const Vec3& p) const {
        std::size_t i0[3], i1[3];
        double f[3];
        for (int a = 0; a < 3; ++a) {
            const double x = std::clamp(p[a], 0.0, double(n_[a] - 1));
            std::size_t i = std::size_t(std::floor(x));
            i = n_[a] >= 2 ? std::min(i, n_[a] - 2) : 0;
            i0[a] = i;
            i1[a] = std::min(i + 1, n_[a] - 1);
            f[a] = x - double(i);
        }
        auto lerp = [](double a, double b, double t) { return a + t * (b - a); };
        const double c00 = lerp(voxel(i0[0], i0[1], i0[2]), voxel(i1[0], i0[1], i0[2]), f[0]);
        const double c10 = lerp(voxel(i0[0], i1[1], i0[2]), voxel(i1[0], i1[1], i0[2]), f[0]);
        const double c01 = lerp(voxel(i0[0], i0[1], i1[2]), voxel(i1[0], i0[1], i1[2]), f[0]);
        const double c11 = lerp(voxel(i0[0], i1[1], i1[2]), voxel(i1[0], i1[1], i1[2]), f[0]);
        return lerp(lerp(c00, c10, f[1]), lerp(c01, c11, f[1]), f[2]);
    }
    /// Macrocell of the point o + tq d and the parameter where the ray leaves it.
    std::size_t cell(const Vec3& o, const Vec3& d, double tq, double& exitT) const {
        const Vec3 p = add(o, scale(d, tq));
        const double B = double(macro_.edge);
        const std::size_t dims[3] = {macro_.nx, macro_.ny, macro_.nz};
        std::size_t c[3];
        double e = kInf;
        for (int a = 0; a < 3; ++a) {
            const double ci = std::clamp(std::floor(p[a] / B), 0.0, double(dims[a] - 1));
            c[a] = std::size_t(ci);
            const double lo = ci * B, hi = std::min(lo + B, double(n_[a] - 1));
            if (d[a] > 0.0)
                e = std::min(e, (hi - p[a]) / d[a]);
            else if (d[a] < 0.0)
                e = std::min(e, (lo - p[a]) / d[a]);
        }
        exitT = tq + std::max(e, 0.0);
        return (c[2] * macro_.ny + c[1]) * macro_.nx + c[0];
    }
    static double eps(const Vec3& d) {
        return 1e-4 / std::max({std::abs(d[0]), std::abs(d[1]), std::abs(d[2])});
    }
    double deltaTrack(const Vec3& o, const Vec3& d, double t, double tEnd, VolclRng& rng, double& tau,
                      Vec3& c) const {
        const double e = eps(d);
        while (t < tEnd) {
            double cellExit;
            const std::size_t ci = cell(o, d, t + e, cellExit);
            const double segEnd = std::min(cellExit, tEnd);
            const double mu = majorant_[ci];
            if (mu > 0.0) {
                for (;;) {
                    t -= std::log(1.0 - uniform(rng)) / mu;
                    if (t >= segEnd) break;
                    const double s = field(add(o, scale(d, t)));
                    tau = tf_.extinctionAt(s);
                    if (uniform(rng) * mu < tau) {
                        const auto rgb = tf_.colorAt(s);
                        c = {rgb[0], rgb[1], rgb[2]};
                        return t;
                    }
                }
            }
            t = segEnd;
        }
        return kInf;
    }
    double transmittance(const Vec3& o, const Vec3& d, double t, double tEnd, VolclRng& rng) const {
        const double e = eps(d);
        double T = 1.0;
        while (t < tEnd) {
            double cellExit;
            const std::size_t ci = cell(o, d, t + e, cellExit);
            const double segEnd = std::min(cellExit, tEnd);
            const double mu = majorant_[ci];
            if (mu > 0.0) {
                for (;;) {
                    t -= std::log(1.0 - uniform(rng)) / mu;
                    if (t >= segEnd) break;
                    T *= std::max(1.0 - tf_.extinctionAt(field(add(o, scale(d, t)))) / mu, 0.0);
                    if (T < 0.1) {
                        if (uniform(rng) >= 0.5) return 0.0;
                        T *= 2.0;
                    }
                }
            }
            t = segEnd;
        }
        return T;
    }

    const Volume& vol_;
    const TransferFunction& tf_;
    SceneEffects fx_;
    std::vector<float> values_;
    Camera cam_;
    ReferenceLighting lighting_;
    grid_detail::MacrocellGrid macro_;
    std::vector<float> majorant_;
    std::vector<Light> lights_;
    std::array<std::size_t, 3> n_{};
};

} // namespace

ImageBuffer pathTraceReference(const Volume& volume, const TransferFunction& tf, const Scene& scene,
                               const PathReferenceOptions& options) {
    if (!scene.effects.scattering || scene.effects.scatteringOrder != ScatteringOrder::Multiple)
        throw UsageError("the path tracer's reference needs effects.scattering.order multiple");
    scene.validate();
    tf.validate();
    const PathReference pr(volume, tf, scene);
    const int samples = options.samples > 0 ? options.samples : scene.effects.samples;
    ImageBuffer img(scene.width, scene.height, {"R", "G", "B", "A"});
    const Camera& cam = pr.camera();
    parallelFor(std::size_t(scene.height), hostThreads(options.threads), [&](std::size_t row) {
        const int y = int(row);
        for (int x = 0; x < scene.width; ++x) {
            const CameraRay ray = cameraRay(cam, scene.width, scene.height, x, y);
            const volcl_rng_u32 pix =
                volcl_rng_u32(std::size_t(y) * std::size_t(scene.width) + std::size_t(x));
            std::array<double, 4> sum{0, 0, 0, 0};
            for (int s = 0; s < samples; ++s) {
                VolclRng rng = volcl_rng_start(scene.effects.seed, pix, volcl_rng_u32(s));
                const auto v = pr.sample(ray, rng);
                for (int c = 0; c < 4; ++c)
                    sum[std::size_t(c)] += v[std::size_t(c)];
            }
            for (int c = 0; c < 4; ++c)
                img.at(x, y, c) = float(sum[std::size_t(c)] / double(samples));
        }
    });
    return img;
}

} // namespace volcl
