// Effect planning for every renderer: which kernel features a scene needs, and why the others were dropped.
#pragma once

#include "core/runtime/ClRuntime.hpp"
#include "render/Bounds.hpp"
#include "render/Scene.hpp"

#include <cstddef>
#include <cstdint>
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
    bool gradientTf = false;          ///< TF_GRADIENT: the TF classifies by gradient magnitude too
    bool labels = false;              ///< LABELS: a label map classifies the samples with the TF
    int gradientCache = 0;   ///< GRADIENT_CACHE: 1 trilinear blend, 2 nearest node, 3 exact blend (grids)
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

/// The packet kernel (raymarch_packet, PACKET_KERNEL in cl/render/raymarch.cl) takes dvr without iso-surfaces,
/// unlit or shaded from a gradient cache; the per-ray kernel takes the rest. True when the scene is dvr
/// without iso-surfaces and its lighting, if any, needs no more than the cache (no shadow rays, scattering or
/// pre-integrated lighting).
bool packetServesLit(const Scene& scene, const EffectPlan& p);

/// Shading from the renderer's gradient cache (GRADIENT_CACHE 1 or `trilinearDefine` trilinear, 2 nearest)
/// when the scene asks for it and the packet kernel takes the scene, else on-the-fly central differences, with
/// the reason in the report. `bytes`: the cache's size; `maxAllocBytes`: the device's largest buffer (0:
/// unknown); `how`: what the cache holds and when it is built, for the report; `trilinearDefine`: 3 for a
/// grid's exact form.
void planGradientCache(const Scene& scene, std::size_t bytes, std::uint64_t maxAllocBytes,
                       std::string_view how, EffectPlan& p, int trilinearDefine = 1);

class TransferFunction;

/// A gradient TF (TransferFunction::usesGradient()) is drawn by the grid and brick ray marchers' per-ray kernel
/// in dvr with point sampling; UsageError, before anything changes, for any other renderer (`rendererDraws`
/// false, naming `renderer`) or scene: pre-integration (its tables have no gradient axis), other modes,
/// iso-surfaces, shadows, scattering. Nothing for a TF without gradient terms.
void checkGradientTf(const Scene& scene, const TransferFunction& tf, bool rendererDraws,
                     std::string_view renderer);

/// A label map (Scene::labels) is drawn by the grid ray marcher's per-ray kernel in dvr with point sampling;
/// UsageError, one line naming the label file, for any other renderer (`rendererDraws` false) or scene:
/// other modes, pre-integration, iso-surfaces, shadows, scattering, gradient TFs. Nothing without labels.
void checkLabels(const Scene& scene, const TransferFunction& tf, bool rendererDraws);

/// A gradient TF: TF_GRADIENT and its line in the report; with widgets, empty-space skipping is dropped (a
/// macrocell the value axis maps to zero may hold a widget's boundary). Nothing for a TF without them.
void planGradientTf(const TransferFunction& tf, EffectPlan& plan);

} // namespace volcl
