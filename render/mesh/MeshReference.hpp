// The exact double-precision ray caster of tetrahedral meshes: the reference every mesh renderer is measured
// against (cell by cell, each segment's linear scalar integrated through the exact TF).
#pragma once

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

/// The shared planner on the mesh's box and value range, with what meshes do not do dropped (shadows,
/// scattering, cubic filters, smoothing, Sobel gradients: a tet's gradient is exact and constant), and
/// pre-integration "2d" served by the 3D table (cell segments differ in length).
EffectPlan planMeshEffects(const Scene& scene, const mesh::TetMesh& mesh);

/// Renders the scene of a mesh exactly, in double, on the host (ReferenceOptions::threads threads; the step
/// is unused: nothing is sampled). Rays start at t = 0 (the eye), enter at boundary faces (a BVH of them),
/// walk face-adjacent tets leaving each through the nearest face plane ahead, and re-enter after a
/// boundary exit (non-convex meshes, holes, any number of times); only the parts inside the mesh and the clip
/// planes count. When the nearest boundary face ahead is one the ray leaves by (an eye inside the mesh, or tets
/// folded over one another past a boundary face) the walk starts in the tet holding the ray's point, found by
/// walking back from that face, so every part of the ray inside some tet counts once.
/// Per mode:
/// - dvr: each segment [t_a, t_b] of a tet has s linear from s_a to s_b; its colour and opacity are the
///   exact emission-absorption integral of the TF (the pre-integration reference), composited front to
///   back. render.preintegration and render.step do not change the reference (they are the renderers'
///   approximations of this integral). Shading: Blinn-Phong with the tet's constant gradient, lights
///   evaluated at the segment's midpoint (exact for directional lights and orthographic head lights),
///   applied to the segment as rgb' = K rgb + S alpha (lighting is affine in the colour).
/// - iso (and dvr with iso-surfaces): crossings of the linear field are exact inside each segment, lit
///   with the tet's gradient; dvr splits the segment there. Z is the ray distance to the first surface.
/// - mip: the largest s over the segment ends (exact for a linear field); colour as for grids.
/// - xray: 1 - exp(-integral of tau), the integral exact per segment.
/// Output as the renderers': R, G, B, A linear associated (+ Z with iso-surfaces). Throws UsageError for an
/// invalid scene, DataError for an invalid TF.
ImageBuffer meshReferenceRender(const mesh::TetMesh& mesh, const TransferFunction& tf, const Scene& scene,
                                const ReferenceOptions& options = {});

} // namespace volcl
