// Pieces every double-precision reference renderer shares: camera rays per pixel, clip planes on the ray
// interval, the parallel pixel loop, and the lighting sum (Blinn-Phong, single scattering).
#pragma once

#include "host/image/ImageIo.hpp"
#include "render/Scene.hpp"
#include "render/VecMath.hpp"

#include <array>
#include <functional>
#include <limits>
#include <vector>

namespace volcl {

/// Options of the double-precision reference renderers.
struct ReferenceOptions {
    double step = 0.02; ///< world units; midpoint rule, so errors fall as step^2
    int threads = 0;    ///< 0 = hardware concurrency
};

/// (r, g, b, a, depth) of one pixel: linear associated colour and the distance to the first surface.
using ReferencePixel = std::array<double, 5>;

/// An empty pixel: nothing along the ray, no surface.
inline ReferencePixel emptyReferencePixel() {
    return {0, 0, 0, 0, std::numeric_limits<double>::infinity()};
}

/// Narrows [t0, t1] along the world ray to the half-spaces the planes keep (t is the world distance).
/// Returns false when a plane parallel to the ray excludes all of it; the interval may still be empty.
bool clipToPlanes(const std::vector<ClipPlane>& planes, const CameraRay& ray, double& t0, double& t1);

/// Renders scene.width x scene.height pixels on `threads` threads (0: all cores): each pixel's camera ray
/// (cameraRay() of `camera`) goes through `trace`. Channels R, G, B, A, and Z when `withDepth`.
ImageBuffer traceReferenceImage(const Scene& scene, const Camera& camera, bool withDepth, int threads,
                                const std::function<ReferencePixel(const CameraRay&)>& trace);

/// The scene's lights and lighting terms as every reference evaluates them (the scene's semantics, not what
/// a planner compiles, so tests can check what it drops).
class ReferenceLighting {
public:
    ReferenceLighting(const Scene& scene, const Camera& camera);
    bool shading() const noexcept { return shading_; }
    bool shadows() const noexcept { return shadows_; }
    /// Whether light() changes a colour at all.
    bool lit() const noexcept { return shading_ || scattering_; }

    /// Unit direction from world point x toward `light`, and the distance to it (infinite when directional).
    Vec3 lightDir(const Light& light, const CameraRay& ray, const Vec3& x, double& dist) const;

    /// Light reaching the eye from a sample of straight colour c at world point x. `gradient()` gives the
    /// world-space gradient there (called only with shading); `visibility(L, dist)` the transmittance
    /// toward a light (called only with shadows); `gradientMin` is the magnitude below which there is no
    /// normal.
    template <class Gradient, class Visibility>
    Vec3 light(const CameraRay& ray, const Vec3& x, const Vec3& c, double gradientMin, Gradient&& gradient,
               Visibility&& visibility) const {
        if (!shading_ && !scattering_) return c;
        Vec3 N{0, 0, 0};
        double gl = 0.0;
        const Vec3 V = scale(ray.direction, -1.0);
        if (shading_) {
            const Vec3 g = gradient();
            gl = norm(g);
            if (gl > gradientMin) N = scale(g, -1.0 / gl);
            if (dot(N, V) < 0.0) N = scale(N, -1.0);
        }
        Vec3 diffuse{0, 0, 0}, specular{0, 0, 0}, scattered{0, 0, 0};
        for (const auto& l : lights_) {
            double dist;
            const Vec3 L = lightDir(l, ray, x, dist);
            const Vec3 lc = scale(l.color, l.intensity);
            const double vis = shadows_ ? visibility(L, dist) : 1.0;
            if (shading_) {
                if (gl > gradientMin) {
                    const Vec3 H = normalized(add(L, V));
                    diffuse = add(diffuse, scale(lc, vis * std::max(dot(N, L), 0.0)));
                    specular =
                        add(specular, scale(lc, vis * std::pow(std::max(dot(N, H), 0.0), fx_.shininess)));
                } else {
                    diffuse = add(diffuse, scale(lc, vis));
                }
            }
            if (scattering_) {
                if (fx_.octaves > 0) { // the kernel's MS_OCTAVES: a = b = c = 1/2
                    double ak = 1.0, bk = 1.0, gk = fx_.phaseG, sum = 0.0;
                    for (int k = 0; k < fx_.octaves; ++k) {
                        sum += ak * std::pow(vis, bk) * phaseHG(gk, dot(L, ray.direction));
                        ak *= 0.5;
                        bk *= 0.5;
                        gk *= 0.5;
                    }
                    scattered = add(scattered, scale(lc, sum));
                } else {
                    scattered = add(scattered, scale(lc, vis * phase(dot(L, ray.direction))));
                }
            }
        }
        Vec3 out = scattering_ && !fx_.emission && !shading_ ? Vec3{0, 0, 0} : c;
        if (shading_)
            out = add(mul(c, add(Vec3{fx_.ambient, fx_.ambient, fx_.ambient}, scale(diffuse, fx_.diffuse))),
                      scale(specular, fx_.specular));
        if (scattering_) out = add(out, scale(mul(c, scattered), fx_.albedo));
        return out;
    }

private:
    double phase(double cosTheta) const; ///< Henyey-Greenstein
    static double phaseHG(double g, double cosTheta);
    SceneEffects fx_;
    Camera camera_;
    std::vector<Light> lights_;
    bool shading_ = false, scattering_ = false, shadows_ = false;
};

/// Root-mean-square difference over the channels R, G, B, A of two images of one size.
double imageRmse(const ImageBuffer& a, const ImageBuffer& b);

} // namespace volcl
