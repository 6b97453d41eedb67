// Camera framing: named views and orbits around a world box, fitted as ParaView's reset camera does.
#pragma once

#include "core/Volume.hpp"
#include "render/Scene.hpp"

#include <optional>
#include <string_view>

namespace volcl {

/// The centre of a world box.
Vec3 boxCentre(const WorldBox& box);
/// Radius of the box's bounding sphere: half the diagonal (at least 0.5 for a point).
double boxRadius(const WorldBox& box);
/// The volume's box `[origin, origin + (n - 1) * spacing]`.
WorldBox volumeBox(const Volume& volume);

/// Views in world axes: +z is up, +y faces the viewer in `front`, +x is to the viewer's right in `back`.
/// For a volume placed in patient axes (Volume::anatomical; world is RAS) that is: front looks at the
/// face (anterior toward the camera, superior up, the patient's right on the image left, as in 3D
/// Slicer's anterior view), top looks down on the head (anterior up), right at the patient's right side.
/// A volume without orientation has identity direction: world is its index frame (+x along i, ...).
/// front: eye on +y looking -y, up +z;  back: eye on -y, up +z;  right: eye on +x, up +z;
/// left: eye on -x, up +z;  top: eye on +z looking down, up +y;  bottom: eye on -z looking up, up +y;
/// iso: the front view orbited 45 degrees toward +x and 30 degrees up.
enum class NamedView { Front, Back, Left, Right, Top, Bottom, Iso };
NamedView parseNamedView(std::string_view name); ///< throws UsageError listing the names
std::string_view namedViewName(NamedView view);

/// Direction from the target toward the eye, and the up vector.
struct ViewDirection {
    Vec3 towardEye{0, 1, 0}, up{0, 0, 1};
};
ViewDirection namedViewDirection(NamedView view);
/// The front view turned `azimuthDeg` about +z (positive toward +x) and `elevationDeg` up toward +z.
/// The up vector stays in the plane of +z and the view direction, and is +y-ward looking straight down.
ViewDirection orbitDirection(double azimuthDeg, double elevationDeg);

/// ParaView's reset camera: target at the box centre, the bounding sphere of radius R just fills the
/// view. Orthographic: height 2R (divided by the aspect when the image is taller than wide). Perspective:
/// eye at distance R / sin(fov / 2) (fov the narrower of the two view angles). `aspect` = width / height.
Camera frameBox(const WorldBox& box, const ViewDirection& view, Projection projection, double fovYDeg,
                double aspect);

/// `view`, given in world axes, in the index-aligned frame of a volume whose index axes point along the
/// columns of `direction` (orthonormal): both vectors multiplied by direction^T.
ViewDirection viewInVolumeFrame(const ViewDirection& view, const Direction3& direction);

/// frameBox() for a box in the volume's own frame (volumeBox()) seen from the world-axis `view`: the
/// camera sits in the volume's frame, where the renderers march, so a rotated volume renders as a rotated
/// box; it is mirrored (Camera::mirrored) when the direction's determinant is negative.
Camera frameOrientedBox(const WorldBox& box, const Direction3& direction, const ViewDirection& view,
                        Projection projection, double fovYDeg, double aspect);

/// Orthographic height that shows the whole box from `camera`'s eye, target and up (target need not be the
/// centre): twice the largest screen-space distance of a box corner from the view axis, vertically, or
/// horizontally divided by `aspect`.
double fittedOrthographicHeight(const Camera& camera, const WorldBox& box, double aspect);

} // namespace volcl
