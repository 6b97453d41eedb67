// Fills the per-concern kernel parameter structs from a scene, camera, TF and effect plan.
#include "render/FrameParams.hpp"

#include "render/VecMath.hpp"

#include <algorithm>
#include <cmath>

namespace volcl {
namespace {

void put(float* dst, const Vec3& v, float w = 0.0f) {
    for (int i = 0; i < 3; ++i)
        dst[i] = static_cast<float>(v[std::size_t(i)]);
    dst[3] = w;
}

} // namespace

VolclCameraParams cameraParams(const Camera& cam, int width, int height) {
    VolclCameraParams p{};
    const Vec3 f = normalized(sub(cam.target, cam.eye));
    const Vec3 r0 = normalized(cross(f, cam.up));
    const Vec3 u = cross(r0, f);
    const Vec3 r = cam.mirrored ? scale(r0, -1.0) : r0; // see Camera::mirrored
    const double aspect = double(width) / double(height);
    const double half = cam.projection == Projection::Orthographic
                            ? cam.height / 2.0
                            : std::tan(cam.fovYDeg * 3.14159265358979323846 / 360.0);
    put(p.origin, cam.eye);
    put(p.right, scale(r, half * aspect));
    put(p.up, scale(u, half));
    put(p.forward, f);
    p.perspective = cam.projection == Projection::Perspective ? 1u : 0u;
    p.width = volcl_uint(width);
    p.height = volcl_uint(height);
    return p;
}

static_assert(kMaxClipPlanes == VOLCL_MAX_CLIP_PLANES, "the scene's plane limit is the kernels'");

VolclClipParams clipParams(const std::vector<ClipPlane>& planes) {
    VolclClipParams p{};
    p.count = volcl_uint(std::min<std::size_t>(planes.size(), VOLCL_MAX_CLIP_PLANES));
    for (std::size_t i = 0; i < p.count; ++i) {
        const double n = norm(planes[i].normal);
        put(p.plane[i], scale(planes[i].normal, 1.0 / n), float(planes[i].offset / n));
    }
    return p;
}

std::array<double, 2> mipWindow(const Scene& scene, const ValueRange& dataRange) {
    if (scene.window) return {(*scene.window)[0] - 0.5 * (*scene.window)[1], (*scene.window)[1]};
    const double width = dataRange.max - dataRange.min;
    return {dataRange.min, width > 0.0 ? width : 1.0};
}

VolclMarchParams marchParams(const Scene& scene, const ValueRange& dataRange) {
    VolclMarchParams p{};
    p.step = static_cast<float>(scene.step);
    p.earlyTermination = static_cast<float>(scene.earlyTermination);
    const auto w = mipWindow(scene, dataRange);
    p.windowLo = static_cast<float>(w[0]);
    p.windowInvWidth = static_cast<float>(1.0 / w[1]);
    return p;
}

VolclTfParams tfParams(const Scene& scene, const TransferFunction& tf, std::size_t knotCount,
                       int tableLengths) {
    VolclTfParams p{};
    p.knotCount = volcl_uint(knotCount);
    p.tableSize = volcl_uint(scene.tableSize);
    p.domainLo = static_cast<float>(tf.domain[0]);
    p.domainHi = static_cast<float>(tf.domain[1]);
    p.tableMaxLength = static_cast<float>(scene.step);
    p.tableLengths = volcl_uint(std::max(tableLengths, 1));
    if (tf.usesGradient()) {
        p.gradientKnotCount = volcl_uint(tf.packGradientOpacityKnots().size());
        p.widgetCount = volcl_uint(tf.widgets.size());
    }
    return p;
}

VolclLightingParams lightingParams(const Scene& scene, double gradientMin) {
    VolclLightingParams p{};
    const SceneEffects& fx = scene.effects;
    p.shadowStep = static_cast<float>(fx.shadowStep > 0.0 ? fx.shadowStep : scene.step);
    p.gradientMin = static_cast<float>(gradientMin);
    p.ambient = float(fx.ambient);
    p.diffuse = float(fx.diffuse);
    p.specular = float(fx.specular);
    p.shininess = float(fx.shininess);
    p.albedo = float(fx.albedo);
    p.phaseG = float(fx.phaseG);
    unsigned nl = 0;
    for (const auto& l : scene.lights) {
        if (!(l.intensity > 0.0) || nl >= VOLCL_MAX_LIGHTS) continue;
        const float kind = l.kind == LightKind::Directional ? VOLCL_LIGHT_DIRECTIONAL
                           : l.kind == LightKind::Point     ? VOLCL_LIGHT_POINT
                                                            : VOLCL_LIGHT_HEAD;
        put(p.lightPos[nl], l.kind == LightKind::Directional ? normalized(l.vector) : l.vector, kind);
        put(p.lightColor[nl], scale(l.color, l.intensity));
        ++nl;
    }
    p.lightCount = nl;
    return p;
}

VolclIsoParams isoParams(const EffectPlan& plan) {
    VolclIsoParams p{};
    p.count = volcl_uint(std::min<std::size_t>(plan.isosurfaces.size(), VOLCL_MAX_ISOSURFACES));
    for (std::size_t i = 0; i < p.count; ++i) {
        const IsoLayer& iso = plan.isosurfaces[i];
        p.value[i] = float(iso.value);
        const double cs = plan.colorScale;
        put(p.color[i], {iso.rgba[0] * cs, iso.rgba[1] * cs, iso.rgba[2] * cs}, float(iso.rgba[3]));
    }
    return p;
}

} // namespace volcl
