// The grid's double-precision reference: trilinear or cubic B-spline field, fine midpoint steps on the exact
// TF, every mode and effect (camera rays, clip planes, the pixel loop and lighting from
// render/Reference.hpp).
#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "render/FogModel.hpp"
#include "render/FrameParams.hpp"
#include "render/Reference.hpp"
#include "render/grid/BsplineField.hpp"
#include "render/grid/GridDetail.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/grid/LabelField.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace volcl {
namespace {

/// The scene's semantics, independent of what the planner compiles (so tests can check what it drops).
class ReferenceTracer {
public:
    ReferenceTracer(const Volume& v, const TransferFunction& tf, const Scene& s, const ReferenceOptions& o)
        : vol_(v), tf_(tf), scene_(s), clipPlanes_(activeClipPlanes(s.effects)), h_(o.step),
          values_(v.toFloat()), cam_(s.camera ? *s.camera : defaultCamera(v)), lighting_(s, cam_) {
        const Dims& d = v.dims();
        n_ = {d.x, d.y, d.z};
        gradMin_ = grid_detail::gradientThreshold(v);
        const bool marching = s.mode == RenderMode::Dvr || s.mode == RenderMode::Iso;
        if (marching)
            for (const auto& iso : s.effects.isosurfaces)
                if (iso.rgba[3] > 0.0) isos_.push_back(iso);
        shadowStep_ = std::min(s.effects.shadowStep > 0.0 ? s.effects.shadowStep : s.step, 4.0 * h_);
        if (s.filter != ReconstructionFilter::Linear)
            spline_ = bsplineCoefficients<double>(v, s.filter, s.smoothing);
        else if (s.smoothing > 0.0)
            values_ = smoothedVolume(v, s.smoothing).toFloat(); // as the kernel reads them: float voxels
        window_ = mipWindow(s, grid_detail::valueRange(v));
        if (s.effects.fog.enabled && s.mode != RenderMode::Mip && s.mode != RenderMode::Emission)
            fog_.emplace(s.effects.fog, gridBounds(v));
        if (s.labels) labels_ = loadLabelField(*s.labels, v);
    }

    const Camera& camera() const noexcept { return cam_; }

    /// (r, g, b, a, depth) along one camera ray.
    ReferencePixel trace(const CameraRay& ray) const {
        const Vec3 o = toVoxel(ray.origin), d = divide(ray.direction);
        if (fog_) return traceWithFog(ray, o, d);
        double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
        if (!clipBox(o, d, t0, t1)) return emptyReferencePixel();
        if (!clipToPlanes(clipPlanes_, ray, t0, t1)) return emptyReferencePixel();
        if (!(t1 > t0)) return emptyReferencePixel();
        const double L = t1 - t0;
        const long n = std::max(1L, long(std::ceil(L / h_)));
        const double h = L / double(n);
        auto at = [&](double t) { return add(o, scale(d, t)); };

        if (scene_.mode == RenderMode::Mip) {
            double m = -inf();
            for (long k = 0; k <= n; ++k)
                m = std::max(m, sample(at(t0 + double(k) * h)));
            const auto c = tf_.colorAt(m);
            if (scene_.mipColor == MipColor::TfOpacity) {
                const double a = 1.0 - std::exp(-tf_.extinctionAt(m));
                return {c[0] * a, c[1] * a, c[2] * a, a, inf()};
            }
            const double g = std::clamp((m - window_[0]) / window_[1], 0.0, 1.0);
            if (scene_.mipColor == MipColor::Tf) return {c[0] * g, c[1] * g, c[2] * g, g, inf()};
            return {g, g, g, g, inf()};
        }
        if (scene_.mode == RenderMode::Xray) {
            double depth = 0.0;
            for (long k = 0; k < n; ++k)
                depth += tf_.extinctionAt(sample(at(t0 + (double(k) + 0.5) * h))) * h;
            const double a = 1.0 - std::exp(-depth);
            return {a, a, a, a, inf()};
        }
        if (scene_.mode == RenderMode::Emission) { // c tau summed at the midpoints, nothing absorbed
            Vec3 sum{0, 0, 0};
            for (long k = 0; k < n; ++k) {
                const double s = sample(at(t0 + (double(k) + 0.5) * h));
                if (!std::isfinite(s)) continue;
                const auto c = tf_.colorAt(s);
                sum = add(sum, scale(Vec3{c[0], c[1], c[2]}, tf_.extinctionAt(s) * h));
            }
            return {sum[0], sum[1], sum[2], 0.0, inf()};
        }
        Vec3 rgb{0, 0, 0};
        double T = 1.0, depth = inf();
        // Iso-surface crossings are exact (independent of the step); each is composited before the segment
        // that holds it, as in the kernel.
        const auto hits =
            isos_.empty() ? std::vector<std::pair<double, std::size_t>>{} : isoHits(o, d, t0, t1);
        std::size_t nextHit = 0;
        for (long k = 0; k < n; ++k) {
            const double ta = t0 + double(k) * h, tb = k + 1 == n ? t1 : t0 + double(k + 1) * h;
            for (; nextHit < hits.size() && hits[nextHit].first <= tb; ++nextHit)
                isoComposite(o, d, ray, hits[nextHit].first, isos_[hits[nextHit].second], rgb, T, depth);
            if (scene_.mode == RenderMode::Dvr) {
                const double tm = 0.5 * (ta + tb);
                const Vec3 pm = at(tm);
                const auto c0 = classify(pm);
                const double a = 1.0 - std::exp(-c0[3] * h);
                if (a > 0.0) {
                    const Vec3 c =
                        light(ray, add(ray.origin, scale(ray.direction, tm)), pm, {c0[0], c0[1], c0[2]});
                    rgb = add(rgb, scale(c, T * a));
                    T *= 1.0 - a;
                }
            }
            if (T < 1e-12) break; // below anything a float image can show
        }
        return {rgb[0], rgb[1], rgb[2], 1.0 - T, depth};
    }

private:
    static double inf() { return std::numeric_limits<double>::infinity(); }

    /// dvr, iso and x-ray with fog: the fog's extinction and emission added to the volume's at every midpoint
    /// (section by section between the volume's and the fog box's ends and the base crossing, so the
    /// midpoint rule never straddles a jump).
    ReferencePixel traceWithFog(const CameraRay& ray, const Vec3& o, const Vec3& d) const {
        double t0 = 0.0, t1 = inf();
        const bool vol = clipBox(o, d, t0, t1) && clipToPlanes(clipPlanes_, ray, t0, t1) && t1 > t0;
        double f0 = 0.0, f1 = inf();
        const bool fog = fog_->clip(ray.origin, ray.direction, f0, f1);
        if (!vol && !fog) return emptyReferencePixel();
        std::vector<double> cuts;
        if (vol) cuts.insert(cuts.end(), {t0, t1});
        if (fog) cuts.insert(cuts.end(), {f0, f1});
        const double lo = *std::min_element(cuts.begin(), cuts.end()),
                     hi = *std::max_element(cuts.begin(), cuts.end());
        const double b = dot(ray.direction, fog_->up());
        if (!fog_->hasMap() && b != 0.0) {
            const double tc = (fog_->effect().base - dot(ray.origin, fog_->up())) / b;
            if (tc > lo && tc < hi) cuts.push_back(tc);
        }
        std::sort(cuts.begin(), cuts.end());
        const Vec3 fogColor = fog_->effect().color;
        auto at = [&](double t) { return add(o, scale(d, t)); };
        Vec3 rgb{0, 0, 0};
        double T = 1.0, depth = inf(), optical = 0.0;
        const auto hits =
            isos_.empty() || !vol ? std::vector<std::pair<double, std::size_t>>{} : isoHits(o, d, t0, t1);
        std::size_t nextHit = 0;
        for (std::size_t c = 0; c + 1 < cuts.size(); ++c) {
            const double a0 = cuts[c], a1 = cuts[c + 1];
            if (!(a1 > a0)) continue;
            const long n = std::max(1L, long(std::ceil((a1 - a0) / h_)));
            const double h = (a1 - a0) / double(n);
            for (long k = 0; k < n; ++k) {
                const double ta = a0 + double(k) * h, tb = k + 1 == n ? a1 : a0 + double(k + 1) * h;
                for (; nextHit < hits.size() && hits[nextHit].first <= tb; ++nextHit)
                    isoComposite(o, d, ray, hits[nextHit].first, isos_[hits[nextHit].second], rgb, T, depth);
                const double tm = 0.5 * (ta + tb);
                const Vec3 xw = add(ray.origin, scale(ray.direction, tm));
                const double sf = fog_->extinction(xw);
                double tau = 0.0;
                Vec3 cv{0, 0, 0};
                if (vol && tm >= t0 && tm <= t1 && scene_.mode != RenderMode::Iso) {
                    const Vec3 pm = at(tm);
                    const auto c0 = classify(pm);
                    tau = c0[3];
                    if (tau > 0.0 && scene_.mode == RenderMode::Dvr) {
                        cv = light(ray, xw, pm, {c0[0], c0[1], c0[2]});
                    }
                }
                const double sigma = tau + sf;
                if (scene_.mode == RenderMode::Xray) {
                    optical += sigma * (tb - ta);
                    continue;
                }
                if (sigma <= 0.0) continue;
                const double a = -std::expm1(-sigma * (tb - ta));
                rgb = add(rgb, scale(add(scale(cv, tau), scale(fogColor, sf)), T * a / sigma));
                T *= 1.0 - a;
            }
        }
        if (scene_.mode == RenderMode::Xray) {
            const double a = -std::expm1(-optical);
            return {a, a, a, a, inf()};
        }
        return {rgb[0], rgb[1], rgb[2], 1.0 - T, depth};
    }
    Vec3 toVoxel(const Vec3& w) const {
        return {(w[0] - vol_.origin[0]) / vol_.spacing[0], (w[1] - vol_.origin[1]) / vol_.spacing[1],
                (w[2] - vol_.origin[2]) / vol_.spacing[2]};
    }
    Vec3 divide(const Vec3& w) const {
        return {w[0] / vol_.spacing[0], w[1] / vol_.spacing[1], w[2] / vol_.spacing[2]};
    }

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

    /// The field at voxel coordinates (clamped), as in the kernel: the spline, or trilinear.
    double sample(const Vec3& p) const {
        if (spline_) return bsplineValue(*spline_, p);
        return grid_detail::trilinear(values_, n_, p);
    }

    /// (r, g, b, tau) of the sample at voxel point p: the TF at its value, and at its gradient magnitude (data
    /// value per world unit) when the TF has gradient terms.
    std::array<double, 4> classify(const Vec3& p) const {
        const double s = sample(p);
        if (tf_.usesGradient()) {
            const Vec3 g = gradient(p);
            return tf_.classify(s, std::sqrt(dot(g, g)));
        }
        const auto c = tf_.colorAt(s);
        if (labels_) return classifyLabels(*labels_, p, {c[0], c[1], c[2], tf_.extinctionAt(s)});
        return {c[0], c[1], c[2], tf_.extinctionAt(s)};
    }

    Vec3 gradient(const Vec3& p) const {
        Vec3 g{0, 0, 0};
        if (spline_) {
            bsplineValue(*spline_, p, &g); // the analytic derivative; Sobel does not apply
        } else if (scene_.effects.gradient == GradientKind::Sobel) {
            for (int a = -1; a <= 1; ++a)
                for (int b = -1; b <= 1; ++b) {
                    const double w = (a == 0 ? 2.0 : 1.0) * (b == 0 ? 2.0 : 1.0);
                    g[0] += w * (sample(add(p, {1, double(a), double(b)})) -
                                 sample(add(p, {-1, double(a), double(b)})));
                    g[1] += w * (sample(add(p, {double(a), 1, double(b)})) -
                                 sample(add(p, {double(a), -1, double(b)})));
                    g[2] += w * (sample(add(p, {double(a), double(b), 1})) -
                                 sample(add(p, {double(a), double(b), -1})));
                }
            g = scale(g, 1.0 / 32.0);
        } else {
            g = {0.5 * (sample(add(p, {1, 0, 0})) - sample(add(p, {-1, 0, 0}))),
                 0.5 * (sample(add(p, {0, 1, 0})) - sample(add(p, {0, -1, 0}))),
                 0.5 * (sample(add(p, {0, 0, 1})) - sample(add(p, {0, 0, -1})))};
        }
        return {g[0] / vol_.spacing[0], g[1] / vol_.spacing[1], g[2] / vol_.spacing[2]};
    }

    double shadow(const Vec3& x, const Vec3& L, double dist) const {
        const Vec3 o = toVoxel(x), d = divide(L);
        double t0 = 0.0, t1 = dist;
        if (!clipBox(o, d, t0, t1)) return 1.0;
        const long n = std::max(1L, long(std::ceil((t1 - t0) / shadowStep_)));
        const double h = (t1 - t0) / double(n);
        double depth = 0.0;
        for (long k = 0; k < n; ++k)
            depth += tf_.extinctionAt(sample(add(o, scale(d, t0 + (double(k) + 0.5) * h)))) * h;
        return std::exp(-depth);
    }

    /// Light reaching the eye from straight colour c at world point x (voxel point p).
    Vec3 light(const CameraRay& ray, const Vec3& x, const Vec3& p, const Vec3& c) const {
        return lighting_.light(
            ray, x, c, gradMin_, [&] { return gradient(p); },
            [&](const Vec3& L, double dist) { return shadow(x, L, dist); });
    }

    /// Every crossing of every iso-value along the ray in [t0, t1], in ray order: the ray is walked cell by
    /// cell, the trilinear field along it is an exact cubic per cell, split at its derivative's roots into
    /// monotone pieces whose crossings are bisected to the last bit of a double. Sides are s >= iso or s <
    /// iso (as in the kernel); a side change on a cell face is a crossing there.
    std::vector<std::pair<double, std::size_t>> isoHits(const Vec3& o, const Vec3& d, double t0,
                                                        double t1) const {
        if (spline_) return splineIsoHits(o, d, t0, t1);
        std::vector<std::pair<double, std::size_t>> hits;
        long c[3];
        int dir[3];
        double tNext[3], tDelta[3];
        const Vec3 p0 = add(o, scale(d, t0));
        for (int a = 0; a < 3; ++a) {
            const long top = std::max(long(n_[a]) - 2, 0L);
            dir[a] = d[a] > 0.0 ? 1 : d[a] < 0.0 ? -1 : 0;
            const double f = d[a] < 0.0 ? std::ceil(p0[a]) - 1.0 : std::floor(p0[a]);
            c[a] = std::clamp(long(std::clamp(f, -1.0, double(top) + 1.0)), 0L, top);
            tNext[a] = dir[a] == 0 ? inf() : (double(c[a] + (dir[a] > 0 ? 1 : 0)) - o[a]) / d[a];
            tDelta[a] = dir[a] == 0 ? inf() : 1.0 / std::abs(d[a]);
        }
        std::vector<char> inside(isos_.size(), 0);
        bool started = false;
        double ta = t0;
        while (ta < t1) {
            const double tOut = std::min({tNext[0], tNext[1], tNext[2]});
            const double tb = std::min(t1, tOut);
            if (tb > ta) isoCell(o, d, c, ta, tb, inside, started, hits);
            ta = std::max(ta, tb);
            if (ta >= t1) break;
            const int a = tNext[0] <= tNext[1] && tNext[0] <= tNext[2] ? 0 : tNext[1] <= tNext[2] ? 1 : 2;
            c[a] += dir[a];
            tNext[a] += tDelta[a];
        }
        std::stable_sort(hits.begin(), hits.end(),
                         [](const auto& x, const auto& y) { return x.first < y.first; });
        return hits;
    }

    /// Crossings on the piece [ta, tb] of the ray inside DDA cell c (clamped to the grid).
    void isoCell(const Vec3& o, const Vec3& d, const long* cell, double ta, double tb,
                 std::vector<char>& inside, bool& started,
                 std::vector<std::pair<double, std::size_t>>& hits) const {
        std::size_t i0[3], i1[3];
        Vec3 a;
        const Vec3 p = add(o, scale(d, ta));
        for (int k = 0; k < 3; ++k) {
            const long top = std::max(long(n_[k]) - 2, 0L);
            i0[k] = std::size_t(std::clamp(cell[k], 0L, top));
            i1[k] = std::min(i0[k] + 1, n_[k] - 1);
            a[k] = p[k] - double(i0[k]);
        }
        double v[2][2][2];
        double lo = inf(), hi = -inf();
        for (int z = 0; z < 2; ++z)
            for (int y = 0; y < 2; ++y)
                for (int x = 0; x < 2; ++x) {
                    v[z][y][x] = voxel(x ? i1[0] : i0[0], y ? i1[1] : i0[1], z ? i1[2] : i0[2]);
                    lo = std::min(lo, v[z][y][x]);
                    hi = std::max(hi, v[z][y][x]);
                }
        // s = k0 + kx x + ky y + kz z + kxy xy + kxz xz + kyz yz + kxyz xyz over the cell's unit cube.
        const double k0 = v[0][0][0], kx = v[0][0][1] - k0, ky = v[0][1][0] - k0, kz = v[1][0][0] - k0;
        const double kxy = v[0][1][1] - v[0][1][0] - v[0][0][1] + k0;
        const double kxz = v[1][0][1] - v[1][0][0] - v[0][0][1] + k0;
        const double kyz = v[1][1][0] - v[1][0][0] - v[0][1][0] + k0;
        const double kxyz =
            v[1][1][1] - v[1][1][0] - v[1][0][1] - v[0][1][1] + v[1][0][0] + v[0][1][0] + v[0][0][1] - k0;
        // Along x = a + u d: s = c3 u^3 + c2 u^2 + c1 u + c0.
        const double c3 = kxyz * d[0] * d[1] * d[2];
        const double c2 = (kxy + kxyz * a[2]) * d[0] * d[1] + (kxz + kxyz * a[1]) * d[0] * d[2] +
                          (kyz + kxyz * a[0]) * d[1] * d[2];
        const double c1 = (kx + kxy * a[1] + kxz * a[2] + kxyz * a[1] * a[2]) * d[0] +
                          (ky + kxy * a[0] + kyz * a[2] + kxyz * a[0] * a[2]) * d[1] +
                          (kz + kxz * a[0] + kyz * a[1] + kxyz * a[0] * a[1]) * d[2];
        const double c0 = k0 + kx * a[0] + ky * a[1] + kz * a[2] + kxy * a[0] * a[1] + kxz * a[0] * a[2] +
                          kyz * a[1] * a[2] + kxyz * a[0] * a[1] * a[2];
        auto s = [&](double u) { return ((c3 * u + c2) * u + c1) * u + c0; };
        // Monotone pieces: split at the real roots of 3 c3 u^2 + 2 c2 u + c1 inside (0, len).
        const double len = tb - ta;
        std::vector<double> knots{0.0};
        const double A = 3.0 * c3, B = 2.0 * c2, C = c1;
        if (A != 0.0) {
            const double disc = B * B - 4.0 * A * C;
            if (disc >= 0.0) {
                const double q = -0.5 * (B + std::copysign(std::sqrt(disc), B));
                if (q != 0.0) {
                    knots.push_back(q / A);
                    knots.push_back(C / q);
                } else {
                    knots.push_back(0.0); // B = C = 0: the only stationary point is u = 0
                }
            }
        } else if (B != 0.0) {
            knots.push_back(-C / B);
        }
        knots.erase(
            std::remove_if(knots.begin() + 1, knots.end(), [&](double u) { return !(u > 0.0 && u < len); }),
            knots.end());
        std::sort(knots.begin(), knots.end());
        knots.push_back(len);
        for (std::size_t i = 0; i < isos_.size(); ++i) {
            const double iso = isos_[i].value;
            const bool crossing = lo < iso && iso <= hi;
            const char side0 = crossing ? s(0.0) >= iso : iso <= lo;
            if (!started) inside[i] = side0;
            if (side0 != inside[i]) hits.push_back({ta, i});
            char side = side0;
            if (crossing)
                for (std::size_t j = 1; j < knots.size(); ++j) {
                    const char next = s(knots[j]) >= iso;
                    if (next == side) continue;
                    double l = knots[j - 1], r = knots[j];
                    for (int it = 0; it < 200; ++it) {
                        const double m = 0.5 * (l + r);
                        if (!(m > l && m < r)) break;
                        if ((s(m) >= iso) == bool(side))
                            l = m;
                        else
                            r = m;
                    }
                    hits.push_back({ta + 0.5 * (l + r), i});
                    side = next;
                }
            inside[i] = side;
        }
        started = true;
    }

    /// Crossings of the spline field, which the scene defines on the march's lattice: side changes between
    /// samples at t0 + k * render.step and the exit (the ray's first sample sets the sides), bisected to the
    /// last bit of a double.
    std::vector<std::pair<double, std::size_t>> splineIsoHits(const Vec3& o, const Vec3& d, double t0,
                                                              double t1) const {
        std::vector<std::pair<double, std::size_t>> hits;
        const double step = scene_.step;
        const long n = std::max(1L, long(std::ceil((t1 - t0) / step)));
        auto f = [&](double t) { return sample(add(o, scale(d, t))); };
        double ta = t0, fa = f(t0);
        for (long k = 1; k <= n; ++k) {
            const double tb = k == n ? t1 : std::min(t0 + double(k) * step, t1), fb = f(tb);
            for (std::size_t i = 0; i < isos_.size(); ++i) {
                const double iso = isos_[i].value;
                const bool sa = fa >= iso;
                if (sa == (fb >= iso)) continue;
                double l = ta, r = tb;
                for (int it = 0; it < 200; ++it) {
                    const double m = 0.5 * (l + r);
                    if (!(m > l && m < r)) break;
                    if ((f(m) >= iso) == sa)
                        l = m;
                    else
                        r = m;
                }
                hits.push_back({0.5 * (l + r), i});
            }
            ta = tb;
            fa = fb;
        }
        std::stable_sort(hits.begin(), hits.end(),
                         [](const auto& x, const auto& y) { return x.first < y.first; });
        return hits;
    }

    void isoComposite(const Vec3& o, const Vec3& d, const CameraRay& ray, double t, const IsoLayer& iso,
                      Vec3& rgb, double& T, double& depth) const {
        const Vec3 c = light(ray, add(ray.origin, scale(ray.direction, t)), add(o, scale(d, t)),
                             {iso.rgba[0], iso.rgba[1], iso.rgba[2]});
        if (std::isinf(depth)) depth = t;
        rgb = add(rgb, scale(c, T * iso.rgba[3]));
        T *= 1.0 - iso.rgba[3];
    }

    const Volume& vol_;
    const TransferFunction& tf_;
    const Scene& scene_;
    std::vector<ClipPlane> clipPlanes_; ///< the scene's clip planes and its crop box's
    double h_;
    std::vector<float> values_;
    std::array<std::size_t, 3> n_{};
    Camera cam_;
    ReferenceLighting lighting_;
    double gradMin_ = 0.0, shadowStep_ = 1.0;
    std::vector<IsoLayer> isos_;
    std::optional<BsplineCoefficients<double>> spline_; ///< the cubic filters' coefficients
    std::array<double, 2> window_{0.0, 1.0};            ///< MIP window: lower end, width
    std::optional<FogField> fog_;                       ///< the scene's fog (not in mip mode)
    std::optional<LabelField> labels_;                  ///< the scene's label map
};

} // namespace

ImageBuffer referenceRender(const Volume& volume, const TransferFunction& tf, const Scene& scene,
                            const ReferenceOptions& options) {
    scene.validate();
    tf.validate();
    checkGradientTf(scene, tf, true, {});
    checkLabels(scene, tf, true);
    if (!(options.step > 0.0)) throw UsageError("reference step must be > 0");
    // The NaN colour's rules live in the kernels only (docs/rendering.md, "NaN and Inf").
    if (const std::size_t n = grid_detail::nonFiniteCount(volume))
        throw DataError("volume has " + std::to_string(n) +
                        " NaN/Inf voxels: the double reference renders finite data only (render without "
                        "--reference)");
    const ReferenceTracer tracer(volume, tf, scene, options);
    const bool depth = (scene.mode == RenderMode::Iso || scene.mode == RenderMode::Dvr) &&
                       std::any_of(scene.effects.isosurfaces.begin(), scene.effects.isosurfaces.end(),
                                   [](const IsoLayer& i) { return i.rgba[3] > 0.0; });
    return traceReferenceImage(scene, tracer.camera(), depth, options.threads,
                               [&](const CameraRay& ray) { return tracer.trace(ray); });
}

} // namespace volcl
