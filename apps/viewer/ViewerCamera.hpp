// Interactive camera motion for the viewer: orbit, pan and zoom of a lookAt camera (eye, target, up).
#pragma once

#include "render/Scene.hpp"

namespace volcl::viewer {

/// Orbit/pan/zoom on a volcl::Camera, keeping the GLM lookAt convention of docs/contract.md. Orbiting turns the eye around
/// the target (yaw about the camera's up vector, pitch about its right vector) and carries `up` along, so the
/// camera passes over the poles without flipping. Example:
/// ```
/// volcl::viewer::CameraController cam(volcl::defaultCamera(volume));
/// cam.orbit(0.1, 0.0);           // 0.1 rad to the right
/// cam.zoom(0.8);                 // 20 % closer
/// scene.camera = cam.camera();
/// ```
class CameraController {
public:
    explicit CameraController(const Camera& camera);
    const Camera& camera() const noexcept { return camera_; }

    /// Turns the eye about the target: `yaw` about up, then `pitch` about right (radians).
    void orbit(double yaw, double pitch);
    /// Moves eye and target sideways; `dx`, `dy` are fractions of the view height (positive: content moves
    /// right / up on screen, as when dragging it).
    void pan(double dx, double dy);
    /// Scales the view: orthographic height or perspective eye distance times `factor` (> 0).
    void zoom(double factor);
    /// Height of the view in world units at the target (orthographic height, or the perspective frustum).
    double viewHeight() const;

private:
    void orthonormalise();
    Camera camera_;
};

/// Rotates `v` about the unit axis `axis` by `angle` radians (Rodrigues).
Vec3 rotateAbout(const Vec3& v, const Vec3& axis, double angle);

} // namespace volcl::viewer
