// Quantised-sphere normal and depth errors and the shading roughness of surface images.
#include "render/grid/FilterAccuracy.hpp"

#include "render/VecMath.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

namespace volcl {
namespace {

constexpr double kMinCosView = 0.3; // 72.5 degrees

/// Calls fn(ray, hit distance, true normal) for every measured pixel.
template <class Fn>
void forMeasuredPixels(const ImageBuffer& img, const Scene& s, const Vec3& centre, Fn&& fn) {
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const double depth = img.at(x, y, 4);
            if (!std::isfinite(depth)) continue;
            const CameraRay ray = cameraRay(*s.camera, s.width, s.height, x, y);
            const Vec3 nTrue = normalized(sub(add(ray.origin, scale(ray.direction, depth)), centre));
            if (std::abs(dot(nTrue, ray.direction)) < kMinCosView) continue;
            fn(x, y, ray, depth, nTrue);
        }
}

} // namespace

Volume quantisedSphere(Dims dims, const Vec3& centre, double radius, double slope) {
    Volume v(dims, ScalarType::UInt8);
    auto vals = v.values<std::uint8_t>();
    for (std::size_t k = 0; k < dims.z; ++k)
        for (std::size_t j = 0; j < dims.y; ++j)
            for (std::size_t i = 0; i < dims.x; ++i) {
                const double r = norm(sub(Vec3{double(i), double(j), double(k)}, centre));
                vals[v.index(i, j, k)] =
                    std::uint8_t(std::lround(std::clamp(128.0 + slope * (radius - r), 0.0, 255.0)));
            }
    return v;
}

Scene sphereNormalScene(const Vec3& centre, double radius, int size) {
    Scene s;
    Camera c;
    c.target = centre;
    c.eye = add(centre, Vec3{20.0, -30.0, -60.0});
    c.height = 2.6 * radius;
    s.camera = c;
    s.width = size;
    s.height = size;
    s.mode = RenderMode::Iso;
    s.step = 0.25;
    s.earlyTermination = 1.0;
    s.effects.shading = true;
    s.effects.shadingGiven = true;
    s.effects.ambient = 0.0;
    s.effects.diffuse = 1.0;
    s.effects.specular = 0.0;
    s.lights = {Light{LightKind::Head, {0, 0, 0}, {1, 1, 1}, 1.0}};
    s.effects.isosurfaces = {{128.5, {1, 1, 1, 1}}};
    return s;
}

double meanNormalErrorDeg(const ImageBuffer& img, const Scene& s, const Vec3& centre) {
    double sum = 0.0;
    long count = 0;
    forMeasuredPixels(img, s, centre, [&](int x, int y, const CameraRay& ray, double, const Vec3& nTrue) {
        const double cosTrue = std::abs(dot(nTrue, ray.direction));
        const double cosShaded = std::clamp(double(img.at(x, y, 0)), 0.0, 1.0);
        sum += std::abs(std::acos(cosShaded) - std::acos(cosTrue)) * 180.0 / std::numbers::pi;
        ++count;
    });
    return count ? sum / double(count) : 180.0;
}

double meanDepthError(const ImageBuffer& img, const Scene& s, const Vec3& centre, double radius) {
    double sum = 0.0;
    long count = 0;
    forMeasuredPixels(img, s, centre, [&](int, int, const CameraRay& ray, double depth, const Vec3&) {
        // First intersection of the ray with the sphere |x - centre| = radius.
        const Vec3 oc = sub(ray.origin, centre);
        const double b = dot(oc, ray.direction), c = dot(oc, oc) - radius * radius;
        const double disc = b * b - c;
        if (disc < 0.0) return;
        sum += std::abs(depth - (-b - std::sqrt(disc)));
        ++count;
    });
    return count ? sum / double(count) : radius;
}

double shadingRoughness(const ImageBuffer& img) {
    auto lum = [&](int x, int y) {
        return 0.2126 * img.at(x, y, 0) + 0.7152 * img.at(x, y, 1) + 0.0722 * img.at(x, y, 2);
    };
    double sum = 0.0;
    long count = 0;
    for (int y = 1; y + 1 < img.height; ++y)
        for (int x = 1; x + 1 < img.width; ++x) {
            if (!(img.at(x, y, 3) > 0.99 && img.at(x - 1, y, 3) > 0.99 && img.at(x + 1, y, 3) > 0.99 &&
                  img.at(x, y - 1, 3) > 0.99 && img.at(x, y + 1, 3) > 0.99))
                continue;
            sum += std::abs(lum(x - 1, y) + lum(x + 1, y) + lum(x, y - 1) + lum(x, y + 1) - 4.0 * lum(x, y));
            ++count;
        }
    return count ? sum / double(count) : 0.0;
}

} // namespace volcl
