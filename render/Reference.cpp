// Shared reference machinery: clip planes on a ray, the parallel pixel loop, lights in double precision.
#include "render/Reference.hpp"

#include "core/Error.hpp"
#include "core/runtime/ParallelFor.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace volcl {

bool clipToPlanes(const std::vector<ClipPlane>& planes, const CameraRay& ray, double& t0, double& t1) {
    for (const auto& p : planes) {
        const double n = norm(p.normal);
        const double a = (dot(p.normal, ray.origin) + p.offset) / n, b = dot(p.normal, ray.direction) / n;
        if (b > 0.0)
            t0 = std::max(t0, -a / b);
        else if (b < 0.0)
            t1 = std::min(t1, -a / b);
        else if (a < 0.0)
            return false;
    }
    return true;
}

ImageBuffer traceReferenceImage(const Scene& scene, const Camera& camera, bool withDepth, int threads,
                                const std::function<ReferencePixel(const CameraRay&)>& trace) {
    std::vector<std::string> channels{"R", "G", "B", "A"};
    if (withDepth) channels.push_back("Z");
    ImageBuffer img(scene.width, scene.height, channels);
    parallelFor(std::size_t(scene.height), threads > 0 ? unsigned(threads) : 0u, [&](std::size_t row) {
        const int y = int(row);
        for (int x = 0; x < scene.width; ++x) {
            const auto v = trace(cameraRay(camera, scene.width, scene.height, x, y));
            for (int c = 0; c < img.channelCount(); ++c)
                img.at(x, y, c) = static_cast<float>(v[std::size_t(c)]);
        }
    });
    return img;
}

ReferenceLighting::ReferenceLighting(const Scene& s, const Camera& camera) : fx_(s.effects), camera_(camera) {
    const bool marching = s.mode == RenderMode::Dvr || s.mode == RenderMode::Iso;
    for (const auto& l : s.lights)
        if (l.intensity > 0.0) lights_.push_back(l);
    if (!marching) lights_.clear();
    shading_ = s.effects.shading && !lights_.empty();
    scattering_ = s.effects.scattering && s.effects.albedo > 0.0 && !lights_.empty();
    shadows_ = s.effects.shadows && (shading_ || scattering_);
}

Vec3 ReferenceLighting::lightDir(const Light& l, const CameraRay& ray, const Vec3& x, double& dist) const {
    dist = std::numeric_limits<double>::infinity();
    if (l.kind == LightKind::Directional) return normalized(l.vector);
    Vec3 target;
    if (l.kind == LightKind::Point)
        target = l.vector;
    else if (camera_.projection == Projection::Perspective)
        target = ray.origin;
    else
        return scale(ray.direction, -1.0);
    const Vec3 v = sub(target, x);
    dist = norm(v);
    return dist > 0.0 ? scale(v, 1.0 / dist) : scale(ray.direction, -1.0);
}

double ReferenceLighting::phaseHG(double g, double ct) {
    const double denom = 1.0 + g * g - 2.0 * g * ct;
    return (1.0 - g * g) / (4.0 * std::numbers::pi * denom * std::sqrt(denom));
}

double ReferenceLighting::phase(double ct) const {
    const double g = fx_.phaseG;
    const double den = 1.0 + g * g - 2.0 * g * ct;
    return (1.0 - g * g) / (4.0 * 3.14159265358979323846 * den * std::sqrt(den));
}

double imageRmse(const ImageBuffer& a, const ImageBuffer& b) {
    if (a.width != b.width || a.height != b.height) throw UsageError("imageRmse: images differ in size");
    double sum = 0.0;
    std::size_t n = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = 0; c < 4; ++c) {
                const double d = double(a.at(x, y, c)) - double(b.at(x, y, c));
                sum += d * d;
                ++n;
            }
    return std::sqrt(sum / double(n));
}

} // namespace volcl
