// The exact double-precision ray caster of tetrahedral meshes: the reference every mesh renderer is measured
// against (cell by cell, each segment's linear scalar integrated through the exact TF).
#pragma once

#include "cl/volcl_shared.h"
#include "host/image/ImageIo.hpp"
#include "host/mesh/TetMesh.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/EffectPlan.hpp"
#include "render/Reference.hpp"
#include "render/Scene.hpp"

namespace volcl {

/// World box of the mesh (its bounds) and its scalar range.
WorldBox meshBounds(const mesh::TetMesh& mesh);
ValueRange meshValueRange(const mesh::TetMesh& mesh);

/// Whether any point value is NaN or +-Inf; a tet with such a vertex is a NaN cell (docs/rendering.md,
/// "NaN and Inf").
bool meshHasNonFinite(const mesh::TetMesh& mesh);
bool tetHasNonFinite(const mesh::TetMesh& mesh, std::size_t tet);

/// The shared planner on the mesh's box and value range, with what meshes do not do dropped (shadows,
/// scattering, cubic filters, smoothing, Sobel gradients: a tet's gradient is exact and constant), and
/// pre-integration "2d" served by the 3D table (cell segments differ in length).
EffectPlan planMeshEffects(const Scene& scene, const mesh::TetMesh& mesh);

/// World gradient magnitude below which a mesh sample has no normal (lit as facing the light): 1e-6 of the
/// value range over the longest edge.
double meshGradientThreshold(const mesh::TetMesh& mesh);

/// The scene's lights for a mesh renderer working in the frame (p - centre) / scale: the gradient threshold in
/// that frame's units and point lights moved into it (directions and head lights need nothing).
VolclLightingParams meshLightingParams(const Scene& scene, const mesh::TetMesh& mesh, const Vec3& centre,
                                       double scale);

/// Renders the scene of a mesh exactly, in double, on the host (ReferenceOptions::threads threads; the step
/// is unused: nothing is sampled). Rays walk from every entering boundary face along their line (a BVH of
/// them), behind the eye too, in the order of t, through face-adjacent tets leaving each through the nearest
/// face plane ahead, up to a boundary face they leave by; each walk counts only past the end of what earlier
/// walks covered, from t = 0 (the eye) on. So every part of the ray inside some tet counts once: non-convex
/// meshes, holes, any number of exits and re-entries, an eye inside the mesh, tets folded over one another and
/// overlapping components. Only the parts inside the mesh and the clip planes count.
/// Per mode:
/// - dvr: each segment [t_a, t_b] of a tet has s linear from s_a to s_b; its colour and opacity are the
///   exact emission-absorption integral of the TF (the pre-integration reference), composited front to
///   back. render.preintegration and render.step do not change the reference (they are the renderers'
///   approximations of this integral). Shading: Blinn-Phong with the tet's constant gradient ("normals":
///   "flat") or its vertex normals interpolated at the point (the default, "smooth"), lights
///   evaluated at the segment's midpoint (exact for directional lights and orthographic head lights),
///   applied to the segment as rgb' = K rgb + S alpha (lighting is affine in the colour).
/// - iso (and dvr with iso-surfaces): crossings of the linear field are exact inside each segment, lit
///   with the tet's gradient or smooth normal; dvr splits the segment there. Z is the ray distance to the first surface.
/// - mip: the largest s over the segment ends (exact for a linear field); colour as for grids.
/// - xray: 1 - exp(-integral of tau), the integral exact per segment.
/// - NaN cells (a tet with a non-finite vertex value): dvr composites the NaN colour over the segment,
///   alpha = 1 - exp(-tau_nan len), unlit; mip, xray and iso-surfaces ignore them.
/// Output as the renderers': R, G, B, A linear associated (+ Z with iso-surfaces). Throws UsageError for an
/// invalid scene, DataError for an invalid TF.
ImageBuffer meshReferenceRender(const mesh::TetMesh& mesh, const TransferFunction& tf, const Scene& scene,
                                const ReferenceOptions& options = {});

} // namespace volcl
