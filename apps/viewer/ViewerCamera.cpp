// Orbit, pan and zoom of the viewer's lookAt camera.
#include "apps/viewer/ViewerCamera.hpp"

#include "core/Error.hpp"
#include "render/VecMath.hpp"

#include <cmath>

namespace volcl::viewer {

Vec3 rotateAbout(const Vec3& v, const Vec3& axis, double angle) {
    const double c = std::cos(angle), s = std::sin(angle);
    return add(add(scale(v, c), scale(cross(axis, v), s)), scale(axis, dot(axis, v) * (1.0 - c)));
}

CameraController::CameraController(const Camera& camera) : camera_(camera) {
    if (norm(sub(camera_.target, camera_.eye)) <= 0.0) throw UsageError("camera: eye and target coincide");
    orthonormalise();
}

// Keeps `up` exactly perpendicular to the view direction, so repeated rotations never accumulate a tilt
// and cross(f, up) never degenerates.
void CameraController::orthonormalise() {
    const Vec3 f = normalized(sub(camera_.target, camera_.eye));
    Vec3 r = normalized(cross(f, camera_.up));
    if (norm(r) == 0.0) { // up parallel to the view: pick any perpendicular
        r = normalized(cross(f, std::abs(f[1]) < 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0}));
    }
    camera_.up = cross(r, f);
}

void CameraController::orbit(double yaw, double pitch) {
    const Vec3 u = camera_.up;
    Vec3 offset = sub(camera_.eye, camera_.target);
    // Yaw: the eye moves left when the scene should turn right, so rotate by -yaw about up.
    offset = rotateAbout(offset, u, -yaw);
    Vec3 up = u;
    const Vec3 r = normalized(cross(normalized(scale(offset, -1.0)), up));
    offset = rotateAbout(offset, r, pitch);
    up = rotateAbout(up, r, pitch);
    camera_.eye = add(camera_.target, offset);
    camera_.up = up;
    orthonormalise();
}

double CameraController::viewHeight() const {
    if (camera_.projection == Projection::Orthographic) return camera_.height;
    const double dist = norm(sub(camera_.target, camera_.eye));
    return 2.0 * dist * std::tan(camera_.fovYDeg * 3.14159265358979323846 / 360.0);
}

void CameraController::pan(double dx, double dy) {
    const Vec3 f = normalized(sub(camera_.target, camera_.eye));
    const Vec3 r = normalized(cross(f, camera_.up));
    const double h = viewHeight();
    // Dragging content right means moving the camera left.
    const Vec3 move = add(scale(r, -dx * h), scale(camera_.up, -dy * h));
    camera_.eye = add(camera_.eye, move);
    camera_.target = add(camera_.target, move);
}

void CameraController::zoom(double factor) {
    if (!(factor > 0.0) || !std::isfinite(factor)) throw UsageError("camera: zoom factor must be positive");
    if (camera_.projection == Projection::Orthographic) {
        camera_.height *= factor;
    } else {
        camera_.eye = add(camera_.target, scale(sub(camera_.eye, camera_.target), factor));
    }
}

} // namespace volcl::viewer
