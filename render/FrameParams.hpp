// Host side of the per-concern kernel parameter structs (cl/volcl_shared.h) every renderer fills alike.
#pragma once

#include "cl/volcl_shared.h"
#include "host/tf/TransferFunction.hpp"
#include "render/EffectPlan.hpp"
#include "render/Scene.hpp"

#include <array>
#include <cstddef>
#include <vector>

namespace volcl {

/// Camera vectors for pixel rays of a width x height image (the only fields a view change touches).
VolclCameraParams cameraParams(const Camera& camera, int width, int height);
/// The planned clip planes, normals scaled to unit length.
VolclClipParams clipParams(const std::vector<ClipPlane>& planes);
/// Step, early-termination opacity and the MIP window (the scene's, else `dataRange`).
VolclMarchParams marchParams(const Scene& scene, const ValueRange& dataRange);
/// The MIP window as (lower end, width): the scene's centre and width, else the data range (width 1 when
/// the data is constant).
std::array<double, 2> mipWindow(const Scene& scene, const ValueRange& dataRange);
/// TF domain and the pre-integration table's geometry (`tableLengths` slices of the 3D table, 1 for 2D).
VolclTfParams tfParams(const Scene& scene, const TransferFunction& tf, std::size_t knotCount,
                       int tableLengths);
/// Lights with non-zero intensity (at most VOLCL_MAX_LIGHTS), shading and scattering coefficients, shadow
/// step; `gradientMin` is the data's gradient magnitude below which a sample has no normal.
VolclLightingParams lightingParams(const Scene& scene, double gradientMin);
/// The planned iso-surfaces, colours scaled by the plan's colour scale.
VolclIsoParams isoParams(const EffectPlan& plan);

} // namespace volcl
