// Camera framing: named views, orbits, ParaView-style reset camera and orthographic height fitting.
#include "render/CameraFraming.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "render/VecMath.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace volcl {
namespace {

double radians(double deg) {
    return deg * std::numbers::pi / 180.0;
}

struct ViewName {
    NamedView view;
    std::string_view name;
};
constexpr ViewName kViewNames[] = {{NamedView::Front, "front"}, {NamedView::Back, "back"},
                                   {NamedView::Left, "left"},   {NamedView::Right, "right"},
                                   {NamedView::Top, "top"},     {NamedView::Bottom, "bottom"},
                                   {NamedView::Iso, "iso"}};

} // namespace

Vec3 boxCentre(const WorldBox& box) {
    return add(box.origin, scale(box.extent, 0.5));
}

double boxRadius(const WorldBox& box) {
    return std::max(0.5 * norm(box.extent), 0.5);
}

WorldBox volumeBox(const Volume& volume) {
    const Dims& d = volume.dims();
    const Vec3 ext{double(d.x - 1) * volume.spacing[0], double(d.y - 1) * volume.spacing[1],
                   double(d.z - 1) * volume.spacing[2]};
    return {volume.origin, ext};
}

NamedView parseNamedView(std::string_view name) {
    for (const auto& v : kViewNames)
        if (v.name == name) return v.view;
    throw UsageError("--view '" + std::string(name) +
                     "' is unknown (front, back, left, right, top, bottom, iso)");
}

std::string_view namedViewName(NamedView view) {
    for (const auto& v : kViewNames)
        if (v.view == view) return v.name;
    return "front";
}

ViewDirection namedViewDirection(NamedView view) {
    switch (view) {
    case NamedView::Front:
        return {{0, 1, 0}, {0, 0, 1}};
    case NamedView::Back:
        return {{0, -1, 0}, {0, 0, 1}};
    case NamedView::Right:
        return {{1, 0, 0}, {0, 0, 1}};
    case NamedView::Left:
        return {{-1, 0, 0}, {0, 0, 1}};
    case NamedView::Top:
        return {{0, 0, 1}, {0, 1, 0}};
    case NamedView::Bottom:
        return {{0, 0, -1}, {0, 1, 0}};
    case NamedView::Iso:
        return orbitDirection(45.0, 30.0);
    }
    return {};
}

ViewDirection orbitDirection(double azimuthDeg, double elevationDeg) {
    if (!(std::isfinite(azimuthDeg) && std::isfinite(elevationDeg)))
        throw UsageError("--orbit: azimuth and elevation must be finite");
    const double az = radians(azimuthDeg), el = radians(std::clamp(elevationDeg, -90.0, 90.0));
    const Vec3 horizontal{std::sin(az), std::cos(az), 0.0};
    ViewDirection v;
    v.towardEye = {horizontal[0] * std::cos(el), horizontal[1] * std::cos(el), std::sin(el)};
    // Up: +z tilted back by the elevation, i.e. perpendicular to the view in the vertical plane through it.
    v.up = {-horizontal[0] * std::sin(el), -horizontal[1] * std::sin(el), std::cos(el)};
    return v;
}

Camera frameBox(const WorldBox& box, const ViewDirection& view, Projection projection, double fovYDeg,
                double aspect) {
    if (!(aspect > 0.0 && std::isfinite(aspect)))
        throw UsageError("camera framing: image aspect must be > 0");
    const double r = boxRadius(box);
    Camera c;
    c.projection = projection;
    c.fovYDeg = fovYDeg;
    c.target = boxCentre(box);
    c.up = view.up;
    const Vec3 dir = normalized(view.towardEye);
    if (projection == Projection::Orthographic) {
        c.height = aspect >= 1.0 ? 2.0 * r : 2.0 * r / aspect;
        // Outside the sphere, so every ray starts in front of the box.
        c.eye = add(c.target, scale(dir, 2.0 * r));
    } else {
        double half = radians(fovYDeg) / 2.0;
        if (aspect < 1.0) half = std::atan(std::tan(half) * aspect); // the horizontal angle is narrower
        c.eye = add(c.target, scale(dir, r / std::sin(half)));
    }
    return c;
}

ViewDirection viewInVolumeFrame(const ViewDirection& view, const Direction3& d) {
    auto transposed = [&](const Vec3& v) {
        return Vec3{d[0] * v[0] + d[3] * v[1] + d[6] * v[2], d[1] * v[0] + d[4] * v[1] + d[7] * v[2],
                    d[2] * v[0] + d[5] * v[1] + d[8] * v[2]};
    };
    return {transposed(view.towardEye), transposed(view.up)};
}

Camera frameOrientedBox(const WorldBox& box, const Direction3& direction, const ViewDirection& view,
                        Projection projection, double fovYDeg, double aspect) {
    // The bounding sphere and its centre are the same in both frames: only the view turns.
    Camera c = frameBox(box, viewInVolumeFrame(view, direction), projection, fovYDeg, aspect);
    c.mirrored = determinant(direction) < 0.0;
    return c;
}

double fittedOrthographicHeight(const Camera& camera, const WorldBox& box, double aspect) {
    const Vec3 f = normalized(sub(camera.target, camera.eye));
    const Vec3 r = normalized(cross(f, camera.up));
    const Vec3 u = cross(r, f);
    double half = 0.0;
    for (int i = 0; i < 8; ++i) {
        const Vec3 corner{(i & 1) ? box.hi()[0] : box.origin[0], (i & 2) ? box.hi()[1] : box.origin[1],
                          (i & 4) ? box.hi()[2] : box.origin[2]};
        const Vec3 d = sub(corner, camera.target);
        half = std::max({half, std::abs(dot(d, u)), std::abs(dot(d, r)) / aspect});
    }
    return std::max(2.0 * half, 1e-6) * 1.02; // a thin margin so the box edge is not on the last pixel
}

} // namespace volcl
