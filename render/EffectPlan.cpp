// Effect planning shared by every renderer: the scene's requests against the data's box and value range.
#include "render/EffectPlan.hpp"

#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/MemoryBudget.hpp"
#include "render/VecMath.hpp"

#include "host/tf/TransferFunction.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace volcl {
namespace {

/// Fog: compiled when it can change the image (non-zero density, a box the rays can cross, a mode with a ray
/// integral).
void planFog(const Scene& scene, const WorldBox& bounds, EffectPlan& p) {
    const FogEffect& f = scene.effects.fog;
    const WorldBox box = f.box ? *f.box : bounds;
    bool flat = false;
    for (int a = 0; a < 3; ++a)
        flat = flat || !(box.extent[a] > 0.0);
    if (scene.mode == RenderMode::Mip)
        p.dropped.push_back("fog: mode mip takes a maximum, not a ray integral");
    else if (scene.mode == RenderMode::Emission)
        p.dropped.push_back("fog: mode emission absorbs nothing, so fog would only add light");
    else if (f.density <= 0.0)
        p.dropped.push_back("fog: density 0");
    else if (flat)
        p.dropped.push_back("fog: its box has no volume");
    else if (f.falloff == 0.0 && f.heightMap.empty() && [&] {
                 // Nothing below the base inside the box: no fog at all.
                 const Vec3 up = normalized(f.up), lo = box.origin, hi = box.hi();
                 double hmin = std::numeric_limits<double>::infinity();
                 for (int c = 0; c < 8; ++c)
                     hmin = std::min(hmin, dot(up, Vec3{c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1],
                                                        c & 4 ? hi[2] : lo[2]}));
                 return hmin >= f.base;
             }())
        p.dropped.push_back("fog: falloff 0 and the box lies above the base");
    else {
        p.fog = true;
        p.defines.set("FOG");
        std::string what =
            "fog: density " + formatNumber(f.density) +
            (f.heightMap.empty() ? ", base " + formatNumber(f.base)
                                 : ", base from the height map " + f.heightMap.filename().string()) +
            (f.falloff == 0.0 ? ", none above the base" : ", falloff " + formatNumber(f.falloff)) +
            (f.box ? ", in its own box" : ", in the volume's box") +
            "; closed-form optical depth per step, composited exactly with each volume segment";
        if (!f.heightMap.empty()) {
            p.fogMap = true;
            p.defines.set("FOG_MAP");
        }
        if (scene.mode == RenderMode::Xray) what += " (x-ray: its optical depth only)";
        p.compiled.push_back(what);
    }
}

/// A label map (scene "labels"): LABELS 1 replace, 2 modulate, 3 alone (LABEL_NEAREST for the nearest-voxel
/// boundary), per-ray kernel; skipping dropped (a macrocell the TF leaves empty may hold a visible label).
void planLabels(const Scene& scene, EffectPlan& p) {
    if (!scene.labels) return;
    const LabelLayer& l = *scene.labels;
    p.labels = true;
    p.defines.set("LABELS", static_cast<long long>(l.mode == LabelMode::Replace    ? 1
                                                   : l.mode == LabelMode::Modulate ? 2
                                                                                   : 3));
    if (l.nearest) p.defines.set("LABEL_NEAREST");
    p.compiled.push_back(
        "labels " + std::string(labelModeName(l.mode)) + " from " + l.file.filename().string() +
        (l.table.empty() ? ", default palette" : ", table " + l.table.filename().string()) +
        (l.nearest ? "; nearest voxel's label (staircase boundaries)"
                   : "; smooth boundaries (each label weighted by its trilinear indicator)") +
        ", looked up in world coordinates, per-ray kernel");
    if (p.skipping) {
        p.skipping = false;
        p.defines.erase("SKIPPING");
        std::erase_if(p.compiled,
                      [](const std::string& c) { return c.rfind("empty-space skipping:", 0) == 0; });
        p.dropped.push_back("empty-space skipping: macrocells bound the TF, not the labels");
    }
    if (p.gradientCache) {
        p.gradientCache = 0;
        p.defines.erase("GRADIENT_CACHE");
        std::erase_if(p.compiled, [](const std::string& c) { return c.rfind("gradient: cache", 0) == 0; });
        p.dropped.push_back("gradient cache: labels take the per-ray kernel, with central differences");
    }
}

/// What the planning steps share: the scene, the data, and facts about the mode and the lights.
struct PlanInput {
    PlanInput(const Scene& s, const WorldBox& b, const ValueRange& r)
        : scene(s), bounds(b), range(r), marching(s.mode == RenderMode::Dvr || s.mode == RenderMode::Iso),
          modeName(renderModeName(s.mode)) {
        for (const auto& l : s.lights)
            if (l.intensity > 0.0 && (l.color[0] > 0.0 || l.color[1] > 0.0 || l.color[2] > 0.0)) ++litLights;
        canLight = marching && litLights > 0;
        noLight = marching ? "no light with non-zero intensity" : "mode " + modeName + " is unlit";
    }
    const Scene& scene;
    const WorldBox& bounds;
    const ValueRange& range;
    bool marching; ///< dvr or iso: a ray integral with opacity and surfaces
    std::string modeName;
    std::size_t litLights = 0;
    bool canLight = false;
    std::string noLight; ///< why nothing is lit, for the dropped lines
};

/// The mode, MIP's colouring and its window.
void planMode(const PlanInput& in, EffectPlan& p) {
    const Scene& scene = in.scene;
    const RenderMode mode = scene.mode;
    p.defines.set("MODE", static_cast<long long>(mode == RenderMode::Dvr    ? 0
                                                 : mode == RenderMode::Mip  ? 1
                                                 : mode == RenderMode::Iso  ? 2
                                                 : mode == RenderMode::Xray ? 3
                                                                            : 4));
    p.compiled.push_back("mode " + in.modeName);
    if (mode == RenderMode::Emission)
        p.compiled.push_back(
            "emission only: integral of the TF colour x opacity per unit distance along the ray, "
            "no absorption (alpha 0: the light adds to the background)");
    if (mode == RenderMode::Mip) {
        p.defines.set("MIP_COLOR", static_cast<long long>(scene.mipColor == MipColor::Grey ? 0
                                                          : scene.mipColor == MipColor::Tf ? 1
                                                                                           : 2));
        const std::string window = scene.window ? "window centre " + formatNumber((*scene.window)[0]) +
                                                      ", width " + formatNumber((*scene.window)[1])
                                                : "window over the data range " + formatNumber(in.range.min) +
                                                      ".." + formatNumber(in.range.max);
        if (scene.mipColor == MipColor::Grey)
            p.compiled.push_back("MIP colour grey: " + window);
        else if (scene.mipColor == MipColor::Tf)
            p.compiled.push_back(
                "MIP colour tf: transfer-function colour, brightness and coverage from the " + window);
        else {
            p.compiled.push_back("MIP colour tf-opacity: the transfer function's colour and opacity");
            if (scene.window) p.dropped.push_back("window: MIP colour tf-opacity takes opacity from the TF");
        }
    } else if (scene.window) {
        p.dropped.push_back("window: mode " + in.modeName + " is not mip");
    }
}

/// The reconstruction filter and smoothing.
void planFilter(const Scene& scene, EffectPlan& p) {
    if (scene.filter != ReconstructionFilter::Linear) {
        p.defines.set("FILTER_BSPLINE");
        p.compiled.push_back(
            (scene.filter == ReconstructionFilter::Cubic
                 ? std::string("filter cubic: interpolating cubic B-spline (prefiltered), analytic gradient")
                 : std::string(
                       "filter bspline: approximating cubic B-spline of the voxels, analytic gradient")) +
            (scene.smoothing > 0.0
                 ? ", data smoothed by a Gaussian of sigma " + formatNumber(scene.smoothing) + " voxel"
                 : ""));
    } else if (scene.smoothing > 0.0) {
        p.compiled.push_back("filter linear on the data smoothed by a Gaussian of sigma " +
                             formatNumber(scene.smoothing) + " voxel (float voxels)");
    }
}

/// Iso-surfaces: crossed only when min < value <= max (the kernel's sign test), visible only if opaque at
/// all.
void planIsosurfaces(const PlanInput& in, EffectPlan& p) {
    const Scene& scene = in.scene;
    const ValueRange& range = in.range;
    if (!scene.effects.isosurfaces.empty()) {
        if (!in.marching) {
            p.dropped.push_back("isosurfaces: mode " + in.modeName + " draws no surfaces");
        } else {
            for (const auto& iso : scene.effects.isosurfaces) {
                const std::string name = "isosurface " + formatNumber(iso.value);
                if (iso.rgba[3] <= 0.0)
                    p.dropped.push_back(name + ": opacity 0");
                else if (!(iso.value > range.min && iso.value <= range.max))
                    p.dropped.push_back(name + ": outside the data range (" + formatNumber(range.min) + ", " +
                                        formatNumber(range.max) + "], never crossed");
                else
                    p.isosurfaces.push_back(iso);
            }
        }
    }
    if (!p.isosurfaces.empty()) {
        p.defines.set("ISO_COUNT", static_cast<long long>(p.isosurfaces.size()));
        p.compiled.push_back("isosurfaces: " + std::to_string(p.isosurfaces.size()) +
                             (scene.filter == ReconstructionFilter::Linear
                                  ? " (exact roots of the trilinear field per cell, composited in ray order)"
                                  : " (sign changes between samples refined on the spline, composited in ray "
                                    "order)"));
    }
}

/// Blinn-Phong shading (or only its ambient term, folded into the colours) and the Sobel gradient.
void planShading(const PlanInput& in, EffectPlan& p) {
    const Scene& scene = in.scene;
    const SceneEffects& fx = scene.effects;
    if (fx.shading) {
        if (!in.canLight)
            p.dropped.push_back("shading: " + in.noLight + " (rendered unshaded)");
        else if (fx.diffuse == 0.0 && fx.specular == 0.0) {
            p.colorScale = fx.ambient;
            p.dropped.push_back("shading: diffuse and specular are 0, so no gradients; ambient " +
                                formatNumber(fx.ambient) + " folded into the colours");
        } else {
            p.shading = true;
            p.defines.set("SHADING");
            p.compiled.push_back("shading: Blinn-Phong, " + std::to_string(in.litLights) +
                                 " light(s), ambient " + formatNumber(fx.ambient) + ", diffuse " +
                                 formatNumber(fx.diffuse) + ", specular " + formatNumber(fx.specular) +
                                 ", shininess " + formatNumber(fx.shininess));
        }
    }
    if (fx.gradient == GradientKind::Sobel) {
        if (scene.filter != ReconstructionFilter::Linear) {
            p.dropped.push_back("gradient sobel: filter " + std::string(filterName(scene.filter)) +
                                " takes the spline's analytic gradient");
        } else if (p.shading) {
            p.sobel = true;
            p.defines.set("GRADIENT_SOBEL");
            p.compiled.push_back("gradient: Sobel");
        } else {
            p.dropped.push_back("gradient sobel: nothing uses gradients");
        }
    }
}

/// Multiple scattering by the path tracer, which is its own kernel: when it applies, `p` becomes its plan
/// (keeping what was dropped so far) and true is returned.
bool planPathTracer(const PlanInput& in, EffectPlan& p) {
    const Scene& scene = in.scene;
    const SceneEffects& fx = scene.effects;
    const bool skyLit = fx.environment[0] > 0.0 || fx.environment[1] > 0.0 || fx.environment[2] > 0.0;
    if (fx.albedo <= 0.0 && !fx.emission) {
        p.dropped.push_back("scattering: albedo 0 and no emission");
        return false;
    }
    if (scene.mode != RenderMode::Dvr) {
        p.dropped.push_back("scattering multiple: mode " + in.modeName + " is not dvr");
        return false;
    }
    if (fx.albedo > 0.0 && !in.canLight && !skyLit) {
        p.dropped.push_back("scattering: " + in.noLight + " and no environment");
        return false;
    }
    // Nothing the ray marcher compiled so far applies.
    EffectPlan q;
    q.dropped = p.dropped;
    p = std::move(q);
    p.defines.set("MODE", 0LL);
    p.compiled.push_back("mode dvr");
    p.pathTracing = true;
    p.scattering = true;
    p.skipping = true;
    p.defines.set("PATH_TRACE");
    p.compiled.push_back(
        "scattering: multiple, Monte Carlo path tracer (delta tracking on the macrocell majorants, "
        "next-event estimation), " +
        std::to_string(fx.samples) + " samples/pixel, up to " + std::to_string(fx.maxBounces) +
        " bounces, Henyey-Greenstein g " + formatNumber(fx.phaseG) + ", albedo " + formatNumber(fx.albedo) +
        ", seed " + std::to_string(fx.seed) + (fx.emission ? "" : ", no emission") +
        (skyLit ? ", environment " + formatNumber(fx.environment[0]) + "," + formatNumber(fx.environment[1]) +
                      "," + formatNumber(fx.environment[2])
                : ""));
    if (fx.shading) p.dropped.push_back("shading: the path tracer lights the medium itself");
    if (scene.filter != ReconstructionFilter::Linear || scene.smoothing > 0.0)
        p.dropped.push_back("filter: the path tracer reads the voxels trilinearly");
    if (scene.earlyTermination < 1.0)
        p.dropped.push_back("early termination: paths end by leaving the volume or Russian roulette");
    if (fx.shadows) p.dropped.push_back("shadows: the path tracer traces its own shadow rays");
    if (!fx.clipPlanes.empty() || fx.cropBox)
        p.dropped.push_back("clip planes and crop box: the path tracer does not clip");
    if (!fx.isosurfaces.empty()) p.dropped.push_back("isosurfaces: the path tracer draws no surfaces");
    if (scene.preintegration != Preintegration::None)
        p.dropped.push_back("pre-integration: the path tracer samples free paths, not segments");
    if (fx.fog.enabled) p.dropped.push_back("fog: the path tracer does not trace through the fog");
    return true;
}

/// Single scattering toward the lights (with its octave approximation of multiple scattering).
void planSingleScattering(const PlanInput& in, EffectPlan& p) {
    const SceneEffects& fx = in.scene.effects;
    if (fx.albedo <= 0.0)
        p.dropped.push_back("scattering: albedo 0");
    else if (!in.canLight)
        p.dropped.push_back("scattering: " + in.noLight);
    else {
        p.scattering = true;
        p.defines.set("SCATTERING");
        p.compiled.push_back("scattering: single, Henyey-Greenstein g " + formatNumber(fx.phaseG) +
                             ", albedo " + formatNumber(fx.albedo));
        if (fx.octaves > 0) {
            p.defines.set("MS_OCTAVES", static_cast<long long>(fx.octaves));
            p.compiled.push_back("multiple scattering approximated by " + std::to_string(fx.octaves) +
                                 " octaves (light a^k through depth b^k, phase c^k g; a = b = c = 1/2)");
        }
        if (!fx.emission) {
            if (p.shading)
                p.dropped.push_back("emission false: shading lights the TF colour as a surface colour");
            else {
                p.defines.set("NO_EMISSION");
                p.compiled.push_back("no emission: the medium only scatters");
            }
        }
    }
}

/// Clip planes and the crop box's faces: those that keep the whole box are dropped.
void planClipping(const Scene& scene, const WorldBox& bounds, EffectPlan& p) {
    const std::vector<ClipPlane> planes = activeClipPlanes(scene.effects);
    const std::size_t userPlanes = scene.effects.clipPlanes.size();
    static constexpr const char* kCropFaces[] = {"x >= x0", "x <= x1", "y >= y0",
                                                 "y <= y1", "z >= z0", "z <= z1"};
    const Vec3 lo = bounds.origin, hi = bounds.hi();
    for (std::size_t i = 0; i < planes.size(); ++i) {
        const ClipPlane& pl = planes[i];
        bool allKept = true;
        for (int c = 0; c < 8; ++c) {
            const Vec3 corner{c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2]};
            if (dot(pl.normal, corner) + pl.offset < 0.0) allKept = false;
        }
        if (allKept)
            p.dropped.push_back((i < userPlanes
                                     ? "clip plane " + std::to_string(i)
                                     : "crop box face " + std::string(kCropFaces[i - userPlanes])) +
                                ": keeps the whole volume");
        else
            p.clipPlanes.push_back(pl);
    }
    if (!p.clipPlanes.empty()) {
        p.clipping = true;
        p.defines.set("CLIPPING");
        p.compiled.push_back("clipping: " + std::to_string(p.clipPlanes.size()) +
                             " plane(s) cut the ray interval");
    }
}

/// Pre-integrated segments: dvr only.
void planPreintegration(const PlanInput& in, EffectPlan& p) {
    const Scene& scene = in.scene;
    if (scene.mode == RenderMode::Emission)
        p.dropped.push_back("pre-integration: mode emission takes midpoint samples (no 1D emission table is "
                            "built; a finer step is its accuracy knob)");
    else if (scene.mode != RenderMode::Dvr)
        p.dropped.push_back("pre-integration: mode " + in.modeName + " integrates no segments");
    else {
        p.defines.set("PREINT", scene.preintegration == Preintegration::Table2d ? 2LL : 3LL);
        p.compiled.push_back(scene.preintegration == Preintegration::Table2d
                                 ? "pre-integration: 2D table at the render step"
                                 : "pre-integration: 3D table over segment lengths");
    }
}

/// The table-based shading effects: pre-integrated lighting and the iso-surface table.
void planTableEffects(const Scene& scene, EffectPlan& p) {
    const RenderMode mode = scene.mode;
    if (scene.effects.shadingPreintegrated) {
        if (!p.shading)
            p.dropped.push_back("pre-integrated lighting: nothing is shaded");
        else if (scene.preintegration != Preintegration::Table2d || mode != RenderMode::Dvr)
            p.dropped.push_back(
                "pre-integrated lighting: needs dvr with render.preintegration 2d (the table is "
                "built for one segment length)");
        else if (p.scattering)
            p.dropped.push_back("pre-integrated lighting: scattering is evaluated per sample");
        else {
            p.preintLighting = true;
            p.defines.set("PREINT_LIGHTING");
            p.compiled.push_back(
                "pre-integrated lighting: gradients at both segment ends, diffuse through the "
                "table's front/back terms, specular at its emission centroid");
        }
    }
    if (scene.effects.isoTable && !p.isosurfaces.empty()) {
        if (mode != RenderMode::Iso)
            p.dropped.push_back(
                "iso-surface table: only in mode iso (dvr mixes surfaces by their exact roots)");
        else {
            p.isoTable = true;
            p.defines.set("ISO_TABLE");
            p.compiled.push_back(
                "iso-surface table: surfaces crossed between a segment's end values, one lookup "
                "per step (the nearest table node of each end)");
        }
    }
}

/// The ray accelerations: empty-space skipping and early termination.
void planAccelerations(const PlanInput& in, std::string_view skippingHow, EffectPlan& p) {
    const Scene& scene = in.scene;
    if (scene.skipping != SkipMode::Off) {
        if (!in.marching)
            p.dropped.push_back("empty-space skipping: mode " + in.modeName + " visits every sample");
        else {
            p.skipping = true;
            p.defines.set("SKIPPING");
            p.compiled.push_back("empty-space skipping: " + std::string(skippingHow));
        }
    }
    if (scene.earlyTermination < 1.0) {
        if (!in.marching)
            p.dropped.push_back("early termination: mode " + in.modeName + " has no opacity to saturate");
        else {
            p.earlyTermination = true;
            p.defines.set("EARLY_TERMINATION");
            p.compiled.push_back("early termination at opacity " + formatNumber(scene.earlyTermination));
        }
    }
}

} // namespace

std::string EffectPlan::explain() const {
    std::ostringstream os;
    os << "compiled: " << defines.toOptions() << '\n';
    for (const auto& c : compiled)
        os << "  + " << c << '\n';
    for (const auto& d : dropped)
        os << "  - dropped " << d << '\n';
    return os.str();
}

EffectPlan planEffects(const Scene& scene, const WorldBox& bounds, const ValueRange& range,
                       std::string_view skippingHow, bool canPathTrace) {
    const PlanInput in(scene, bounds, range);
    const SceneEffects& fx = scene.effects;
    EffectPlan p;
    planMode(in, p);
    planFilter(scene, p);
    planIsosurfaces(in, p);
    planShading(in, p);
    const bool wantsMultiple = fx.scattering && fx.scatteringOrder == ScatteringOrder::Multiple;
    if (wantsMultiple && !canPathTrace)
        p.dropped.push_back(
            "scattering order multiple: this renderer has no path tracer (single scattering instead)");
    const bool multiple = wantsMultiple && canPathTrace;
    if (multiple && planPathTracer(in, p)) return p;
    if (fx.scattering && !multiple) planSingleScattering(in, p);
    if (fx.shadows) {
        if (!p.shading && !p.scattering)
            p.dropped.push_back("shadows: nothing is lit");
        else {
            p.shadows = true;
            p.defines.set("SHADOWS");
            p.compiled.push_back("shadows: secondary marching toward each light");
        }
    }
    if (!fx.clipPlanes.empty() || fx.cropBox) planClipping(scene, bounds, p);
    if (scene.preintegration != Preintegration::None) planPreintegration(in, p);
    if (fx.fog.enabled) planFog(scene, bounds, p);
    planTableEffects(scene, p);
    planAccelerations(in, skippingHow, p);
    planLabels(scene, p);
    return p;
}

double nanExtinction(const Scene& scene) {
    const double a = scene.nanColor[3];
    return a >= 1.0 ? kMaxImportedExtinction : -std::log1p(-a);
}

void planShadowVolume(const Scene& scene, int cell, std::string_view how, EffectPlan& plan) {
    if (!plan.shadows || scene.effects.shadowMethod != ShadowMethod::Volume) return;
    plan.shadowVolume = true;
    plan.defines.set("SHADOW_VOLUME");
    for (std::string& line : plan.compiled)
        if (line.starts_with("shadows:"))
            line = "shadows: a light-attenuation volume per light (" + std::to_string(cell) + "-voxel cells" +
                   std::string(how) + "), one fetch per sample";
}

void planNanColor(const Scene& scene, bool hasNonFinite, EffectPlan& plan) {
    if (!hasNonFinite) return;
    const std::array<double, 4>& c = scene.nanColor;
    plan.defines.set("NAN_COLOR");
    plan.defines.set("NAN_R", c[0]);
    plan.defines.set("NAN_G", c[1]);
    plan.defines.set("NAN_B", c[2]);
    plan.defines.set("NAN_TAU", nanExtinction(scene));
    plan.compiled.push_back(std::string("nan colour: NaN/Inf samples drawn ") +
                            (c[3] > 0.0 ? "as " + formatNumber(c[0]) + "," + formatNumber(c[1]) + "," +
                                              formatNumber(c[2]) + "," + formatNumber(c[3])
                                        : std::string("transparent")) +
                            " (mip and xray skip them)");
}

bool packetServesLit(const Scene& scene, const EffectPlan& p) {
    return scene.mode == RenderMode::Dvr && p.isosurfaces.empty() && !p.scattering && !p.pathTracing &&
           !p.gradientTf && !p.labels && (!p.shadows || p.shadowVolume) && !p.preintLighting;
}

void planGradientCache(const Scene& scene, std::size_t bytes, std::uint64_t maxAllocBytes,
                       std::string_view how, EffectPlan& p, int trilinearDefine) {
    const GradientKind g = scene.effects.gradient;
    if (!p.shading || (g != GradientKind::Cache && g != GradientKind::CacheNearest)) return;
    const std::string name(gradientKindName(g));
    if (scene.filter != ReconstructionFilter::Linear) {
        p.dropped.push_back("gradient " + name + ": filter " + std::string(filterName(scene.filter)) +
                            " takes the spline's analytic gradient");
    } else if (scene.smoothing > 0.0) {
        p.dropped.push_back("gradient " + name + ": smoothing " + formatNumber(scene.smoothing) +
                            " takes central differences of the smoothed voxels");
    } else if (!packetServesLit(scene, p)) {
        p.dropped.push_back(
            "gradient " + name +
            ": iso-surfaces, shadow rays, scattering and pre-integrated lighting take the per-ray "
            "kernel with central differences");
    } else if (bytes > effectiveMemoryBudget(0) || (maxAllocBytes && bytes > maxAllocBytes)) {
        p.dropped.push_back(
            "gradient " + name + ": its " + std::to_string(bytes) +
            " bytes exceed the memory budget or the device's largest buffer; central differences");
    } else {
        p.gradientCache = g == GradientKind::CacheNearest ? 2 : trilinearDefine;
        p.defines.set("GRADIENT_CACHE", static_cast<long long>(p.gradientCache));
        p.compiled.push_back("gradient: cache, " + std::string(how) + "; " +
                             (g == GradientKind::CacheNearest
                                  ? "nearest node's gradient (one fetch)"
                                  : "trilinear blend of the eight nodes' gradients"));
    }
}

namespace {

/// What the per-ray kernel's extra classifications (gradient TFs, labels) draw in: point-sampled dvr without
/// iso-surfaces, shadows or scattering; UsageError naming `what` (`plural`: "labels need", else "... needs")
/// and the table `axis` pre-integration lacks otherwise.
void requirePointSampledDvr(const Scene& scene, const std::string& what, bool plural, std::string_view axis) {
    if (scene.mode != RenderMode::Dvr)
        throw UsageError(what + (plural ? " need" : " needs") + " mode dvr (mode " +
                         std::string(renderModeName(scene.mode)) + ")");
    if (scene.preintegration != Preintegration::None)
        throw UsageError(what + (plural ? " are" : " is") +
                         " point sampled: pre-integration tables have no " + std::string(axis) +
                         " axis (use --preintegration none)");
    if (!scene.effects.isosurfaces.empty()) throw UsageError(what + " cannot be combined with iso-surfaces");
    if (scene.effects.shadows) throw UsageError(what + " cannot be combined with shadows");
    if (scene.effects.scattering) throw UsageError(what + " cannot be combined with scattering");
}

} // namespace

void checkGradientTf(const Scene& scene, const TransferFunction& tf, bool rendererDraws,
                     std::string_view renderer) {
    if (!tf.usesGradient()) return;
    const std::string what = "a transfer function with gradient_opacity or widgets";
    if (!rendererDraws)
        throw UsageError(what + " renders on regular grids and .vcz bricks only, not with " +
                         std::string(renderer));
    requirePointSampledDvr(scene, what, false, "gradient");
}

void checkLabels(const Scene& scene, const TransferFunction& tf, bool rendererDraws) {
    if (!scene.labels) return;
    const std::string what = "labels (" + scene.labels->file.filename().string() + ")";
    if (!rendererDraws)
        throw UsageError(what + " render with the grid ray marcher only, not from .vcz bricks, meshes or "
                                "preview tiers (decode a .vcz first: volcl decode)");
    requirePointSampledDvr(scene, what, true, "label");
    if (tf.usesGradient()) throw UsageError(what + " cannot be combined with a gradient transfer function");
}

void planGradientTf(const TransferFunction& tf, EffectPlan& plan) {
    if (!tf.usesGradient()) return;
    plan.gradientTf = true;
    plan.defines.set("TF_GRADIENT");
    if (plan.gradientCache) {
        plan.gradientCache = 0;
        plan.defines.erase("GRADIENT_CACHE");
        std::erase_if(plan.compiled, [](const std::string& c) { return c.rfind("gradient: cache", 0) == 0; });
        plan.dropped.push_back("gradient cache: a gradient transfer function takes the per-ray kernel, with "
                               "central differences");
    }
    plan.compiled.push_back("gradient transfer function: " + std::to_string(tf.widgets.size()) +
                            " widget(s)" + (tf.gradientOpacity.empty() ? "" : ", gradient opacity") +
                            "; gradient magnitude by central differences per sample, per-ray kernel");
    if (!tf.widgets.empty() && plan.skipping) {
        plan.skipping = false;
        plan.defines.erase("SKIPPING");
        std::erase_if(plan.compiled,
                      [](const std::string& c) { return c.rfind("empty-space skipping:", 0) == 0; });
        plan.dropped.push_back(
            "empty-space skipping: the TF's widgets classify by gradient, which macrocells do "
            "not bound");
    }
}

} // namespace volcl
