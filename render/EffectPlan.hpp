// Effect planning for every renderer: which kernel features a scene needs, and why the others were dropped.
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "render/Bounds.hpp"
#include "render/Scene.hpp"

#include <string>
#include <string_view>
#include <vector>

namespace volcl {

/// The kernel features a scene needs, with the reason each requested feature was kept or dropped.
struct EffectPlan {
    KernelDefines defines;
    std::vector<std::string> compiled; ///< "shading: 2 lights, ambient 0.2 ..."
    std::vector<std::string> dropped;  ///< "shadows: no light in the scene"
    bool shading = false, shadows = false, scattering = false, clipping = false, skipping = false;
    bool shadowVolume = false; ///< shadows from light-attenuation volumes (SHADOW_VOLUME), not rays
    bool earlyTermination = false, sobel = false;
    bool fog = false, fogMap = false; ///< FOG (and FOG_MAP): the scene's fog is composited
    bool preintLighting = false;      ///< PREINT_LIGHTING: shading through the pre-integrated lighting table
    bool isoTable = false;            ///< ISO_TABLE: iso-surfaces from the iso-surface table
    bool pathTracing = false;         ///< multiple scattering: the path tracer renders the frame
    int gradientCache = 0;   ///< GRADIENT_CACHE (grids): 1 trilinear blend, 2 nearest voxel, 3 exact blend
    double colorScale = 1.0; ///< ambient-only shading folded into the TF colours
    std::vector<IsoLayer> isosurfaces; ///< the ones that can appear
    std::vector<ClipPlane> clipPlanes; ///< the ones that cut the data's box
    std::string explain() const;       ///< multi-line report for `volcl render --explain`
};

/// Decides the compiled features from the scene and what every renderer's data has: its world box (clip
/// planes that keep all of it are dropped) and value range (iso-values outside it are never crossed).
/// `skippingHow` names the renderer's empty-space skipping in the report ("8^3-voxel macrocells"). The
/// result holds the effect defines (MODE, PREINT, ISO_COUNT, SHADING, ...); a renderer adds the defines of
/// its data layout (a grid's VOXEL_TYPE) itself. `canPathTrace`: the renderer has a path tracer for
/// `"order": "multiple"` (others render single scattering and say so).
EffectPlan planEffects(const Scene& scene, const WorldBox& bounds, const ValueRange& range,
                       std::string_view skippingHow, bool canPathTrace = false);

/// Shadows by effects.shadow_method "volume": sets shadowVolume and SHADOW_VOLUME and says so in the report
/// ("a light-attenuation volume per light (`cell`-voxel cells`how`)"); nothing when the plan has no shadows or the
/// scene asks for rays. `cell`: the cell the renderer builds (it may be coarser than the scene's).
void planShadowVolume(const Scene& scene, int cell, std::string_view how, EffectPlan& plan);

/// Extinction per unit distance of the scene's NaN colour (opacity a per unit distance: -ln(1 - a)).
double nanExtinction(const Scene& scene);

/// Data with NaN/Inf voxels: adds NAN_COLOR and the colour's NAN_R/G/B/TAU defines and says so in the
/// report. Finite data compiles no NaN test at all.
void planNanColor(const Scene& scene, bool hasNonFinite, EffectPlan& plan);

} // namespace volcl
