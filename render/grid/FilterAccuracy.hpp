// Measures of how well a reconstruction filter recovers a surface from quantised data: an 8-bit sphere,
// the normal error of a shaded image of it, and the terrace roughness of any shaded surface image.
#pragma once

#include "core/Volume.hpp"
#include "host/image/ImageIo.hpp"
#include "render/Scene.hpp"

namespace volcl {

/// An 8-bit grid of a sphere with a shallow radial ramp: round(128 + slope * (radius - |x - centre|)),
/// clamped to [0, 255]. With a slope of a few levels per voxel the trilinear field is a staircase.
Volume quantisedSphere(Dims dims, const Vec3& centre, double radius, double slope);

/// An iso-mode scene of `quantisedSphere` for measuring normals: orthographic, diffuse-only head light
/// (a pixel is cos(normal, view)), one opaque white iso-surface at 128.5 (between two levels), Z output.
Scene sphereNormalScene(const Vec3& centre, double radius, int size);

/// Mean angle in degrees between the shaded normal and the sphere's true normal, over the pixels of an
/// image of sphereNormalScene (R channel = cos of the shaded normal, Z = hit distance) whose true normal is
/// within 72 degrees of the view (near the silhouette a tiny error is a large angle).
double meanNormalErrorDeg(const ImageBuffer& img, const Scene& scene, const Vec3& centre);

/// Mean |depth - true depth| of the hits, in world units, over the same pixels.
double meanDepthError(const ImageBuffer& img, const Scene& scene, const Vec3& centre, double radius);

/// Terrace roughness of a shaded surface image: the mean absolute discrete Laplacian of the luminance
/// over pixels whose 4 neighbours are all covered (alpha > 0.99). Contour-line terraces are steps in
/// shading, so they raise it; a smooth surface keeps only its true curvature.
double shadingRoughness(const ImageBuffer& img);

} // namespace volcl
