// Scene JSON parsing and validation, lighting defaults, default camera, and the double-precision camera
// rays (docs/contract.md, "Scenes and images").
#include "render/Scene.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "preintegration/PreintegrationTable.hpp"
#include "render/VecMath.hpp"
#include "render/mesh/VisibilitySort.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

namespace volcl {
namespace {

using nlohmann::json;

json parse(std::string_view text) {
    try {
        return json::parse(text.begin(), text.end());
    } catch (const json::exception& e) { // parse errors, and numbers beyond double's range (1e400)
        throw UsageError(std::string("scene: invalid JSON (") + e.what() + ")");
    }
}

void checkKeys(const json& j, const std::string& where, std::initializer_list<const char*> allowed) {
    if (!j.is_object()) throw UsageError("scene: '" + where + "' must be an object");
    std::set<std::string> ok(allowed.begin(), allowed.end());
    for (const auto& [key, value] : j.items()) {
        (void)value;
        if (!ok.count(key)) {
            std::string list;
            for (const auto& k : ok)
                list += (list.empty() ? "" : ", ") + k;
            throw UsageError("scene: unknown key '" + key + "' in " + where + " (expected " + list + ")");
        }
    }
}

double num(const json& j, const std::string& where) {
    if (!j.is_number()) throw UsageError("scene: '" + where + "' must be a number");
    const double v = j.get<double>();
    if (!std::isfinite(v)) throw UsageError("scene: '" + where + "' is not finite");
    return v;
}

// A number for an int field. Past int's range the conversion is undefined behaviour (found by
// fuzz_scene_json: "table_lengths": 2.2e56), so such values are refused here; each field's own range is
// checked by validate().
int intField(const json& j, const std::string& where) {
    const double v = num(j, where);
    if (!(v >= -2147483648.0 && v < 2147483648.0)) {
        char shown[32];
        std::snprintf(shown, sizeof(shown), "%g", v);
        throw UsageError("scene: '" + where + "' is out of range (" + shown + ")");
    }
    return static_cast<int>(v);
}

template <std::size_t N> std::array<double, N> vec(const json& j, const std::string& where) {
    if (!j.is_array() || j.size() != N)
        throw UsageError("scene: '" + where + "' must be an array of " + std::to_string(N) + " numbers");
    std::array<double, N> out{};
    for (std::size_t i = 0; i < N; ++i)
        out[i] = num(j[i], where);
    return out;
}

bool flag(const json& j, const std::string& where) {
    if (!j.is_boolean()) throw UsageError("scene: '" + where + "' must be true or false");
    return j.get<bool>();
}

std::string str(const json& j, const std::string& where) {
    if (!j.is_string()) throw UsageError("scene: '" + where + "' must be a string");
    return j.get<std::string>();
}

/// A string field naming one of two values; `expected` lists the names for the error.
template <class T>
T choice(const json& j, const std::string& where, const char* nameA, T a, const char* nameB, T b,
         const char* expected) {
    const std::string v = str(j, where);
    if (v == nameA) return a;
    if (v == nameB) return b;
    throw UsageError("scene: " + where + " '" + v + "' is unknown (" + expected + ")");
}

} // namespace

std::string_view renderModeName(RenderMode m) {
    switch (m) {
    case RenderMode::Dvr:
        return "dvr";
    case RenderMode::Mip:
        return "mip";
    case RenderMode::Iso:
        return "iso";
    case RenderMode::Xray:
        return "xray";
    case RenderMode::Emission:
        return "emission";
    }
    return "dvr";
}

RenderMode parseRenderMode(std::string_view s) {
    if (s == "dvr") return RenderMode::Dvr;
    if (s == "mip") return RenderMode::Mip;
    if (s == "iso") return RenderMode::Iso;
    if (s == "xray") return RenderMode::Xray;
    if (s == "emission") return RenderMode::Emission;
    throw UsageError("render mode '" + std::string(s) +
                     "' is unknown (expected dvr, mip, iso, xray, emission)");
}

std::string_view preintegrationName(Preintegration p) {
    switch (p) {
    case Preintegration::None:
        return "none";
    case Preintegration::Table2d:
        return "2d";
    case Preintegration::Table3d:
        return "3d";
    }
    return "none";
}

Preintegration parsePreintegration(std::string_view s) {
    if (s == "none" || s == "off") return Preintegration::None;
    if (s == "2d") return Preintegration::Table2d;
    if (s == "3d") return Preintegration::Table3d;
    throw UsageError("pre-integration '" + std::string(s) + "' is unknown (expected none, 2d, 3d)");
}

std::string_view skipModeName(SkipMode m) {
    return m == SkipMode::Auto ? "auto" : m == SkipMode::On ? "on" : "off";
}

SkipMode parseSkipMode(std::string_view s) {
    if (s == "auto") return SkipMode::Auto;
    if (s == "on") return SkipMode::On;
    if (s == "off") return SkipMode::Off;
    throw UsageError("skipping '" + std::string(s) + "' is unknown (expected auto, on, off)");
}

std::string_view labelModeName(LabelMode m) {
    return m == LabelMode::Replace ? "replace" : m == LabelMode::Modulate ? "modulate" : "alone";
}

LabelMode parseLabelMode(std::string_view s) {
    if (s == "replace") return LabelMode::Replace;
    if (s == "modulate") return LabelMode::Modulate;
    if (s == "alone") return LabelMode::Alone;
    throw UsageError("label mode '" + std::string(s) + "' is unknown (expected replace, modulate, alone)");
}

std::string_view gradientKindName(GradientKind g) {
    switch (g) {
    case GradientKind::Central:
        return "central";
    case GradientKind::Sobel:
        return "sobel";
    case GradientKind::Cache:
        return "cache";
    case GradientKind::CacheNearest:
        return "cache-nearest";
    }
    return "cache";
}

GradientKind parseGradientKind(std::string_view s) {
    for (GradientKind g :
         {GradientKind::Central, GradientKind::Sobel, GradientKind::Cache, GradientKind::CacheNearest})
        if (s == gradientKindName(g)) return g;
    throw UsageError("gradient '" + std::string(s) + "' is unknown (central, sobel, cache, cache-nearest)");
}

std::string_view filterName(ReconstructionFilter f) {
    switch (f) {
    case ReconstructionFilter::Linear:
        return "linear";
    case ReconstructionFilter::Cubic:
        return "cubic";
    case ReconstructionFilter::Bspline:
        return "bspline";
    }
    return "linear";
}

ReconstructionFilter parseFilter(std::string_view s) {
    if (s == "linear") return ReconstructionFilter::Linear;
    if (s == "cubic") return ReconstructionFilter::Cubic;
    if (s == "bspline") return ReconstructionFilter::Bspline;
    throw UsageError("filter '" + std::string(s) + "' is unknown (expected linear, cubic, bspline)");
}

std::string_view mipColorName(MipColor c) {
    switch (c) {
    case MipColor::Grey:
        return "grey";
    case MipColor::Tf:
        return "tf";
    case MipColor::TfOpacity:
        return "tf-opacity";
    }
    return "grey";
}

MipColor parseMipColor(std::string_view s) {
    if (s == "grey" || s == "gray") return MipColor::Grey;
    if (s == "tf") return MipColor::Tf;
    if (s == "tf-opacity") return MipColor::TfOpacity;
    throw UsageError("MIP colour '" + std::string(s) + "' is unknown (expected grey, tf, tf-opacity)");
}

namespace {

void validateFog(const FogEffect& f);

FogEffect parseFog(const json& f, const std::filesystem::path& baseDir) {
    checkKeys(f, "effects.fog",
              {"density", "base", "falloff", "color", "up", "box", "height_map", "height_range"});
    FogEffect fog;
    fog.enabled = true;
    if (f.contains("density")) fog.density = num(f["density"], "effects.fog.density");
    if (f.contains("base")) fog.base = num(f["base"], "effects.fog.base");
    if (f.contains("falloff")) fog.falloff = num(f["falloff"], "effects.fog.falloff");
    if (f.contains("color")) fog.color = vec<3>(f["color"], "effects.fog.color");
    if (f.contains("up")) fog.up = vec<3>(f["up"], "effects.fog.up");
    if (f.contains("box")) {
        const json& b = f["box"];
        if (!b.is_array() || b.size() != 2)
            throw UsageError("scene: 'effects.fog.box' must be [[x0, y0, z0], [x1, y1, z1]]");
        const Vec3 lo = vec<3>(b[0], "effects.fog.box[0]"), hi = vec<3>(b[1], "effects.fog.box[1]");
        fog.box = WorldBox{lo, {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]}};
    }
    if (f.contains("height_map")) {
        std::filesystem::path p(str(f["height_map"], "effects.fog.height_map"));
        fog.heightMap = p.is_relative() && !baseDir.empty() ? baseDir / p : p;
    }
    if (f.contains("height_range")) fog.heightRange = vec<2>(f["height_range"], "effects.fog.height_range");
    validateFog(fog);
    return fog;
}

} // namespace

std::string_view lodModeName(LodMode m) {
    return m == LodMode::Auto ? "auto" : "full";
}

LodMode parseLodMode(std::string_view s) {
    if (s == "full") return LodMode::Full;
    if (s == "auto") return LodMode::Auto;
    throw UsageError("level of detail '" + std::string(s) + "' is unknown (expected full, auto)");
}

std::string_view meshMethodName(MeshMethod m) {
    switch (m) {
    case MeshMethod::KBuffer:
        return "kbuffer";
    case MeshMethod::ProjectedTetrahedra:
        return "pt";
    case MeshMethod::Cells:
        break;
    }
    return "cells";
}

std::string_view gridMethodName(GridMethod m) {
    return m == GridMethod::ShearWarp ? "shear-warp" : m == GridMethod::Drc ? "drc" : "raymarch";
}

void parseRenderMethod(std::string_view s, const std::string& what, Scene& scene) {
    if (s == "raymarch" || s == "shear-warp" || s == "drc") {
        scene.gridMethod = s == "shear-warp" ? GridMethod::ShearWarp
                           : s == "drc"      ? GridMethod::Drc
                                             : GridMethod::Raymarch;
        return;
    }
    if (s == "cells" || s == "kbuffer" || s == "pt") {
        scene.meshMethod = parseMeshMethod(s);
        return;
    }
    throw UsageError(
        what + " '" + std::string(s) +
        "' is unknown (expected raymarch, shear-warp, drc for grids; cells, kbuffer, pt for meshes)");
}

MeshMethod parseMeshMethod(std::string_view s) {
    if (s == "cells") return MeshMethod::Cells;
    if (s == "kbuffer") return MeshMethod::KBuffer;
    if (s == "pt") return MeshMethod::ProjectedTetrahedra;
    throw UsageError("render.method '" + std::string(s) + "' is unknown (expected cells, kbuffer, pt)");
}

namespace {

/// "camera": every field optional; which of eye, target, up and height were given goes to cameraGiven.
void parseCamera(const json& c, Scene& s) {
    checkKeys(c, "camera", {"projection", "eye", "target", "up", "height", "fov_y_deg"});
    Camera cam;
    if (c.contains("projection")) {
        cam.projection =
            choice(c["projection"], "camera.projection", "orthographic", Projection::Orthographic,
                   "perspective", Projection::Perspective, "orthographic, perspective");
    } else if (c.contains("fov_y_deg")) {
        cam.projection = Projection::Perspective;
    }
    if (c.contains("eye")) cam.eye = vec<3>(c["eye"], "camera.eye");
    if (c.contains("target")) cam.target = vec<3>(c["target"], "camera.target");
    if (c.contains("up")) cam.up = vec<3>(c["up"], "camera.up");
    if (c.contains("height")) cam.height = num(c["height"], "camera.height");
    if (c.contains("fov_y_deg")) cam.fovYDeg = num(c["fov_y_deg"], "camera.fov_y_deg");
    s.camera = cam;
    s.cameraGiven = {c.contains("eye"), c.contains("target"), c.contains("up"), c.contains("height")};
}

/// "image": size and background.
void parseImage(const json& im, Scene& s) {
    checkKeys(im, "image", {"width", "height", "background"});
    if (im.contains("width")) s.width = intField(im["width"], "image.width");
    if (im.contains("height")) s.height = intField(im["height"], "image.height");
    if (im.contains("background")) s.background = vec<4>(im["background"], "image.background");
}

/// "render": mode, step, tables, filter, level of detail, mesh method and sort.
void parseRenderSettings(const json& r, Scene& s) {
    checkKeys(r, "render",
              {"mode", "step", "preintegration", "early_termination", "skipping", "table_size",
               "table_lengths", "filter", "smoothing", "window", "mip_color", "budget_ms", "lod", "lod_error",
               "cache_mb", "method", "k", "sort", "nan_color"});
    if (r.contains("mode")) s.mode = parseRenderMode(str(r["mode"], "render.mode"));
    if (r.contains("step")) {
        if (r["step"].is_string()) {
            const StepSpec st = parseStepSpec(r["step"].get<std::string>(), "render.step");
            (st.voxels ? s.stepVoxels.emplace() : s.step) = st.value;
        } else {
            s.step = num(r["step"], "render.step");
        }
    } else {
        s.stepVoxels = kDefaultStepVoxels;
    }
    if (r.contains("preintegration")) {
        const json& p = r["preintegration"];
        s.preintegration = p.is_boolean() ? (p.get<bool>() ? Preintegration::Table2d : Preintegration::None)
                                          : parsePreintegration(str(p, "render.preintegration"));
    }
    if (r.contains("early_termination"))
        s.earlyTermination = num(r["early_termination"], "render.early_termination");
    if (r.contains("skipping")) {
        const json& k = r["skipping"]; // true/false from before "auto" existed: on/off
        s.skipping = k.is_boolean() ? (k.get<bool>() ? SkipMode::On : SkipMode::Off)
                                    : parseSkipMode(str(k, "render.skipping"));
    }
    if (r.contains("table_size")) s.tableSize = intField(r["table_size"], "render.table_size");
    if (r.contains("table_lengths")) s.tableLengths = intField(r["table_lengths"], "render.table_lengths");
    if (r.contains("filter")) s.filter = parseFilter(str(r["filter"], "render.filter"));
    if (r.contains("smoothing")) s.smoothing = num(r["smoothing"], "render.smoothing");
    if (r.contains("window")) s.window = vec<2>(r["window"], "render.window");
    if (r.contains("mip_color")) s.mipColor = parseMipColor(str(r["mip_color"], "render.mip_color"));
    if (r.contains("budget_ms")) s.budgetMs = num(r["budget_ms"], "render.budget_ms");
    if (r.contains("lod")) s.lod = parseLodMode(str(r["lod"], "render.lod"));
    if (r.contains("lod_error")) s.lodError = num(r["lod_error"], "render.lod_error");
    if (r.contains("cache_mb")) s.cacheMb = num(r["cache_mb"], "render.cache_mb");
    if (r.contains("method")) parseRenderMethod(str(r["method"], "render.method"), "render.method", s);
    if (r.contains("k")) s.kBufferDepth = intField(r["k"], "render.k");
    if (r.contains("sort")) s.meshSort = parseMeshSort(str(r["sort"], "render.sort"));
    if (r.contains("nan_color")) s.nanColor = vec<4>(r["nan_color"], "render.nan_color");
}

/// "lights": an array of directional, point and head lights.
void parseLights(const json& lights, Scene& s) {
    if (!lights.is_array()) throw UsageError("scene: 'lights' must be an array");
    int i = 0;
    for (const json& l : lights) {
        const std::string where = "lights[" + std::to_string(i++) + "]";
        checkKeys(l, where, {"type", "direction", "position", "color", "intensity"});
        Light light;
        const std::string type = l.contains("type") ? str(l["type"], where + ".type") : "directional";
        if (type == "directional") {
            light.kind = LightKind::Directional;
            if (!l.contains("direction")) throw UsageError("scene: " + where + " needs 'direction'");
            light.vector = vec<3>(l["direction"], where + ".direction");
        } else if (type == "point") {
            light.kind = LightKind::Point;
            if (!l.contains("position")) throw UsageError("scene: " + where + " needs 'position'");
            light.vector = vec<3>(l["position"], where + ".position");
        } else if (type == "head") {
            light.kind = LightKind::Head;
        } else {
            throw UsageError("scene: " + where + ".type '" + type +
                             "' is unknown (directional, point, head)");
        }
        if (l.contains("color")) light.color = vec<3>(l["color"], where + ".color");
        if (l.contains("intensity")) light.intensity = num(l["intensity"], where + ".intensity");
        s.lights.push_back(light);
    }
}

/// "effects.shading": true/false, or an object of Blinn-Phong terms (shading on).
void parseShading(const json& sh, SceneEffects& fx) {
    fx.shadingGiven = true;
    if (sh.is_boolean()) {
        fx.shading = sh.get<bool>();
    } else {
        checkKeys(sh, "effects.shading",
                  {"ambient", "diffuse", "specular", "shininess", "preintegrated", "normals"});
        if (sh.contains("normals")) {
            const std::string n = str(sh["normals"], "effects.shading.normals");
            if (n != "flat" && n != "smooth")
                throw UsageError("effects.shading.normals must be \"flat\" or \"smooth\" (got \"" + n +
                                 "\")");
            fx.smoothNormals = n == "smooth";
        }
        if (sh.contains("preintegrated"))
            fx.shadingPreintegrated = flag(sh["preintegrated"], "effects.shading.preintegrated");
        fx.shading = true;
        if (sh.contains("ambient")) fx.ambient = num(sh["ambient"], "effects.shading.ambient");
        if (sh.contains("diffuse")) fx.diffuse = num(sh["diffuse"], "effects.shading.diffuse");
        if (sh.contains("specular")) fx.specular = num(sh["specular"], "effects.shading.specular");
        if (sh.contains("shininess")) fx.shininess = num(sh["shininess"], "effects.shading.shininess");
    }
}

/// "effects.scattering": single or multiple scattering and the path tracer's settings.
void parseScattering(const json& sc, SceneEffects& fx) {
    checkKeys(sc, "effects.scattering",
              {"albedo", "g", "order", "samples", "bounces", "seed", "environment", "emission", "octaves"});
    fx.scattering = true;
    if (sc.contains("albedo")) fx.albedo = num(sc["albedo"], "effects.scattering.albedo");
    if (sc.contains("g")) fx.phaseG = num(sc["g"], "effects.scattering.g");
    if (sc.contains("order"))
        fx.scatteringOrder =
            choice(sc["order"], "effects.scattering.order", "single", ScatteringOrder::Single, "multiple",
                   ScatteringOrder::Multiple, "single, multiple");
    auto count = [&](const char* key, double lo, double hi) {
        const double v = num(sc[key], std::string("effects.scattering.") + key);
        if (!(v >= lo && v <= hi) || v != std::floor(v))
            throw UsageError(std::string("scene: effects.scattering.") + key + " must be an integer in [" +
                             std::to_string(long(lo)) + ", " + std::to_string(long(hi)) + "]");
        return v;
    };
    if (sc.contains("samples")) fx.samples = int(count("samples", 1, 1 << 20));
    if (sc.contains("bounces")) fx.maxBounces = int(count("bounces", 1, 4096));
    if (sc.contains("seed")) fx.seed = std::uint32_t(count("seed", 0, 4294967295.0));
    if (sc.contains("environment"))
        fx.environment = vec<3>(sc["environment"], "effects.scattering.environment");
    if (sc.contains("emission")) fx.emission = flag(sc["emission"], "effects.scattering.emission");
    if (sc.contains("octaves")) fx.octaves = int(count("octaves", 0, 8));
}

/// "effects.clip_planes": normal with an offset or a point on the plane.
void parseClipPlanes(const json& planes, SceneEffects& fx) {
    if (!planes.is_array()) throw UsageError("scene: 'effects.clip_planes' must be an array");
    int i = 0;
    for (const json& p : planes) {
        const std::string where = "effects.clip_planes[" + std::to_string(i++) + "]";
        checkKeys(p, where, {"normal", "offset", "point"});
        ClipPlane plane;
        if (!p.contains("normal")) throw UsageError("scene: " + where + " needs 'normal'");
        plane.normal = vec<3>(p["normal"], where + ".normal");
        if (p.contains("point")) {
            const Vec3 q = vec<3>(p["point"], where + ".point");
            plane.offset = -dot(plane.normal, q);
        } else if (p.contains("offset")) {
            plane.offset = num(p["offset"], where + ".offset");
        }
        fx.clipPlanes.push_back(plane);
    }
}

/// "effects.crop_box": {"box": [[x0, y0, z0], [x1, y1, z1]], "units": "world" | "voxels"}.
CropBox parseCropBox(const json& c) {
    if (!c.is_object()) throw UsageError("scene: 'effects.crop_box' must be an object with 'box'");
    checkKeys(c, "effects.crop_box", {"box", "units"});
    if (!c.contains("box")) throw UsageError("scene: effects.crop_box needs 'box'");
    const json& b = c["box"];
    if (!b.is_array() || b.size() != 2)
        throw UsageError("scene: 'effects.crop_box.box' must be [[x0, y0, z0], [x1, y1, z1]]");
    CropBox box;
    box.lo = vec<3>(b[0], "effects.crop_box.box[0]");
    box.hi = vec<3>(b[1], "effects.crop_box.box[1]");
    if (c.contains("units"))
        box.voxels =
            choice(c["units"], "effects.crop_box.units", "voxels", true, "world", false, "world, voxels");
    return box;
}

/// "effects.isosurfaces": value and colour per surface.
void parseIsosurfaces(const json& surfaces, SceneEffects& fx) {
    if (!surfaces.is_array()) throw UsageError("scene: 'effects.isosurfaces' must be an array");
    int i = 0;
    for (const json& p : surfaces) {
        const std::string where = "effects.isosurfaces[" + std::to_string(i++) + "]";
        checkKeys(p, where, {"value", "color"});
        IsoLayer iso;
        if (!p.contains("value")) throw UsageError("scene: " + where + " needs 'value'");
        iso.value = num(p["value"], where + ".value");
        if (p.contains("color")) iso.rgba = vec<4>(p["color"], where + ".color");
        fx.isosurfaces.push_back(iso);
    }
}

/// "effects".
void parseEffects(const json& e, const std::filesystem::path& baseDir, SceneEffects& fx) {
    checkKeys(e, "effects",
              {"shading", "gradient", "shadows", "shadow_step", "shadow_method", "light_volume_cell",
               "shadow_head_tolerance", "scattering", "clip_planes", "crop_box", "isosurfaces", "fog",
               "isosurface_method"});
    if (e.contains("shading")) parseShading(e["shading"], fx);
    if (e.contains("gradient")) try {
            fx.gradient = parseGradientKind(str(e["gradient"], "effects.gradient"));
        } catch (const UsageError& err) {
            throw UsageError(std::string("scene: effects.") + err.what());
        }
    if (e.contains("shadows")) fx.shadows = flag(e["shadows"], "effects.shadows");
    if (e.contains("shadow_step")) fx.shadowStep = num(e["shadow_step"], "effects.shadow_step");
    if (e.contains("shadow_method"))
        fx.shadowMethod = choice(e["shadow_method"], "effects.shadow_method", "volume", ShadowMethod::Volume,
                                 "rays", ShadowMethod::Rays, "volume, rays");
    if (e.contains("light_volume_cell"))
        fx.lightVolumeCell = intField(e["light_volume_cell"], "effects.light_volume_cell");
    if (e.contains("shadow_head_tolerance"))
        fx.headLightToleranceDeg = num(e["shadow_head_tolerance"], "effects.shadow_head_tolerance");
    if (e.contains("scattering")) parseScattering(e["scattering"], fx);
    if (e.contains("clip_planes")) parseClipPlanes(e["clip_planes"], fx);
    if (e.contains("crop_box")) fx.cropBox = parseCropBox(e["crop_box"]);
    if (e.contains("isosurfaces")) parseIsosurfaces(e["isosurfaces"], fx);
    if (e.contains("fog")) fx.fog = parseFog(e["fog"], baseDir);
    if (e.contains("isosurface_method"))
        fx.isoTable = choice(e["isosurface_method"], "effects.isosurface_method", "table", true, "roots",
                             false, "roots, table");
}

} // namespace

Scene Scene::fromJson(std::string_view text, const std::filesystem::path& baseDir) {
    const json j = parse(text);
    checkKeys(j, "the scene",
              {"volume", "tf", "camera", "image", "render", "lights", "effects", "labels", "channels",
               "blend", "color"});
    Scene s;
    auto path = [&](const json& v, const char* where) {
        const std::string text = str(v, where);
        std::filesystem::path p(text);
        // A built-in "preset:NAME" is a name, not a file beside the scene.
        if (text.starts_with("preset:")) return p;
        return p.is_relative() && !baseDir.empty() ? baseDir / p : p;
    };
    if (j.contains("volume")) s.volume = path(j["volume"], "volume");
    if (j.contains("tf")) s.tf = path(j["tf"], "tf");
    if (j.contains("channels")) {
        if (!j["channels"].is_array() || j["channels"].empty())
            throw UsageError("scene: channels must be a non-empty list of {\"tf\", \"visible\", \"volume\", "
                             "\"channel\"}");
        for (const json& c : j["channels"]) {
            if (!c.is_object()) throw UsageError("scene: each of channels must be an object");
            checkKeys(c, "a channel", {"tf", "visible", "volume", "channel"});
            SceneChannel sc;
            if (c.contains("tf")) sc.tf = path(c["tf"], "channels.tf");
            if (c.contains("visible")) sc.visible = flag(c["visible"], "channels.visible");
            if (c.contains("volume")) sc.volume = path(c["volume"], "channels.volume");
            if (c.contains("channel")) {
                if (!c["channel"].is_number_unsigned())
                    throw UsageError("scene: channels.channel must be a channel index (0, 1, ...)");
                sc.channel = c["channel"].get<std::size_t>();
            }
            s.channels.push_back(std::move(sc));
        }
    }
    if (j.contains("blend")) {
        s.channelBlend = str(j["blend"], "blend");
        if (s.channelBlend != "additive" && s.channelBlend != "max")
            throw UsageError("scene: blend '" + s.channelBlend + "' is unknown (expected additive, max)");
    }
    if (j.contains("color")) {
        const std::string c = str(j["color"], "color");
        if (c != "direct" && c != "tf")
            throw UsageError("scene: color '" + c + "' is unknown (expected direct, tf)");
        s.directColor = c == "direct";
    }
    if (j.contains("camera")) parseCamera(j["camera"], s);
    if (j.contains("image")) parseImage(j["image"], s);
    if (j.contains("render")) parseRenderSettings(j["render"], s);
    if (j.contains("lights")) parseLights(j["lights"], s);
    if (j.contains("effects")) parseEffects(j["effects"], baseDir, s.effects);
    if (j.contains("labels")) {
        const json& l = j["labels"];
        if (!l.is_object() || !l.contains("file"))
            throw UsageError(
                "scene: 'labels' must be an object with 'file' (and 'table', 'mode', 'boundary')");
        checkKeys(l, "labels", {"file", "table", "mode", "boundary"});
        LabelLayer layer;
        layer.file = path(l["file"], "labels.file");
        if (l.contains("table")) layer.table = path(l["table"], "labels.table");
        if (l.contains("mode")) {
            try {
                layer.mode = parseLabelMode(str(l["mode"], "labels.mode"));
            } catch (const UsageError& e) {
                throw UsageError(std::string("scene: labels.mode: ") + e.what());
            }
        }
        if (l.contains("boundary"))
            layer.nearest =
                choice(l["boundary"], "labels.boundary", "nearest", true, "smooth", false, "smooth, nearest");
        s.labels = layer;
    }
    return s;
}

Scene Scene::fromFile(const std::filesystem::path& path) {
    requireRegularFile(path); // a FIFO would block the read, a device never end
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(path.string() + ": cannot open scene file");
    std::ostringstream text;
    text << in.rdbuf();
    try {
        return fromJson(text.str(), path.parent_path());
    } catch (const UsageError& e) {
        throw UsageError(path.string() + ": " + e.what());
    }
}

std::string Scene::toJson() const {
    json j;
    if (!volume.empty()) j["volume"] = volume.string();
    if (!tf.empty()) j["tf"] = tf.string();
    if (labels) {
        j["labels"] = {{"file", labels->file.string()},
                       {"mode", std::string(labelModeName(labels->mode))},
                       {"boundary", labels->nearest ? "nearest" : "smooth"}};
        if (!labels->table.empty()) j["labels"]["table"] = labels->table.string();
    }
    for (const SceneChannel& c : channels) {
        json e;
        if (!c.tf.empty()) e["tf"] = c.tf.string();
        e["visible"] = c.visible;
        if (!c.volume.empty()) e["volume"] = c.volume.string();
        if (c.channel) e["channel"] = *c.channel;
        j["channels"].push_back(e);
    }
    if (!channels.empty()) j["blend"] = channelBlend;
    if (directColor) j["color"] = "direct";
    if (camera) {
        json c;
        c["projection"] = camera->projection == Projection::Perspective ? "perspective" : "orthographic";
        c["eye"] = camera->eye;
        c["target"] = camera->target;
        c["up"] = camera->up;
        if (camera->projection == Projection::Perspective)
            c["fov_y_deg"] = camera->fovYDeg;
        else
            c["height"] = camera->height;
        j["camera"] = c;
    }
    j["image"] = {{"width", width}, {"height", height}, {"background", background}};
    j["render"] = {{"mode", std::string(renderModeName(mode))},
                   {"step", stepVoxels ? json(formatNumber(*stepVoxels, 17) + "vox") : json(step)},
                   {"preintegration", std::string(preintegrationName(preintegration))},
                   {"early_termination", earlyTermination},
                   {"skipping", std::string(skipModeName(skipping))},
                   {"table_size", tableSize},
                   {"table_lengths", tableLengths},
                   {"filter", std::string(filterName(filter))},
                   {"smoothing", smoothing},
                   {"mip_color", std::string(mipColorName(mipColor))},
                   {"lod", std::string(lodModeName(lod))},
                   {"lod_error", lodError},
                   {"cache_mb", cacheMb}};
    // Mesh fields only when set (grid scenes' JSON stays as it was).
    if (meshMethod != MeshMethod::Cells) j["render"]["method"] = std::string(meshMethodName(meshMethod));
    if (gridMethod != GridMethod::Raymarch) j["render"]["method"] = std::string(gridMethodName(gridMethod));
    if (kBufferDepth != 6) j["render"]["k"] = kBufferDepth;
    if (meshSort) j["render"]["sort"] = std::string(meshSortName(*meshSort));
    if (window) j["render"]["window"] = *window;
    if (budgetMs > 0.0) j["render"]["budget_ms"] = budgetMs;
    if (nanColor != std::array<double, 4>{0, 0, 0, 0}) j["render"]["nan_color"] = nanColor;
    j["lights"] = json::array();
    for (const auto& l : lights) {
        json o;
        o["type"] = l.kind == LightKind::Directional ? "directional"
                    : l.kind == LightKind::Point     ? "point"
                                                     : "head";
        if (l.kind == LightKind::Directional) o["direction"] = l.vector;
        if (l.kind == LightKind::Point) o["position"] = l.vector;
        o["color"] = l.color;
        o["intensity"] = l.intensity;
        j["lights"].push_back(o);
    }
    json e = json::object();
    if (effects.shading) {
        e["shading"] = {{"ambient", effects.ambient},
                        {"diffuse", effects.diffuse},
                        {"specular", effects.specular},
                        {"shininess", effects.shininess}};
        if (effects.shadingPreintegrated) e["shading"]["preintegrated"] = true;
        if (!effects.smoothNormals) e["shading"]["normals"] = "flat";
    }
    if (effects.isoTable) e["isosurface_method"] = "table";
    e["gradient"] = std::string(gradientKindName(effects.gradient));
    if (effects.shadows) e["shadows"] = true;
    e["shadow_step"] = effects.shadowStep;
    e["shadow_method"] = effects.shadowMethod == ShadowMethod::Rays ? "rays" : "volume";
    e["light_volume_cell"] = effects.lightVolumeCell;
    e["shadow_head_tolerance"] = effects.headLightToleranceDeg;
    if (effects.scattering) {
        e["scattering"] = {{"albedo", effects.albedo}, {"g", effects.phaseG}};
        if (!effects.emission) e["scattering"]["emission"] = false;
        if (effects.octaves > 0) e["scattering"]["octaves"] = effects.octaves;
        if (effects.scatteringOrder == ScatteringOrder::Multiple) {
            json& sc = e["scattering"];
            sc["order"] = "multiple";
            sc["samples"] = effects.samples;
            sc["bounces"] = effects.maxBounces;
            sc["seed"] = effects.seed;
            sc["environment"] = effects.environment;
            sc["emission"] = effects.emission;
        }
    }
    if (!effects.clipPlanes.empty()) {
        e["clip_planes"] = json::array();
        for (const auto& p : effects.clipPlanes)
            e["clip_planes"].push_back({{"normal", p.normal}, {"offset", p.offset}});
    }
    if (effects.cropBox)
        e["crop_box"] = {{"box", {effects.cropBox->lo, effects.cropBox->hi}},
                         {"units", effects.cropBox->voxels ? "voxels" : "world"}};
    if (!effects.isosurfaces.empty()) {
        e["isosurfaces"] = json::array();
        for (const auto& i : effects.isosurfaces)
            e["isosurfaces"].push_back({{"value", i.value}, {"color", i.rgba}});
    }
    if (effects.fog.enabled) {
        const FogEffect& f = effects.fog;
        json fj = {{"density", f.density},
                   {"base", f.base},
                   {"falloff", f.falloff},
                   {"color", f.color},
                   {"up", f.up}};
        if (f.box) fj["box"] = {f.box->origin, f.box->hi()};
        if (!f.heightMap.empty()) fj["height_map"] = f.heightMap.string();
        if (f.heightRange) fj["height_range"] = *f.heightRange;
        e["fog"] = fj;
    }
    j["effects"] = e;
    return j.dump(2);
}

namespace {
std::string shortNumber(double v);

/// The fog's own ranges (also checked while a scene file is read, so the error names the file).
void validateFog(const FogEffect& f) {
    auto need = [](bool ok, const std::string& msg) {
        if (!ok) throw UsageError("scene: " + msg);
    };
    // NaN fails every comparison, so each test below also refuses it.
    need(f.density >= 0.0 && f.density <= 1e30,
         "effects.fog.density must be in [0, 1e30] (got " + shortNumber(f.density) + ")");
    need(f.falloff >= 0.0 && f.falloff <= 1e30,
         "effects.fog.falloff must be in [0, 1e30] (0: no fog above the base; got " + shortNumber(f.falloff) +
             ")");
    need(std::isfinite(f.base) && std::abs(f.base) <= 1e30, "effects.fog.base must be finite");
    for (double c : f.color)
        need(c >= 0.0 && c <= 1e30, "effects.fog.color values must be >= 0 (and finite)");
    need(std::isfinite(norm(f.up)) && norm(f.up) > 0.0, "effects.fog.up must be non-zero");
    if (f.box)
        for (int a = 0; a < 3; ++a)
            need(std::isfinite(f.box->origin[a]) && f.box->extent[a] >= 0.0 &&
                     std::isfinite(f.box->extent[a]),
                 "effects.fog.box must be [[x0, y0, z0], [x1, y1, z1]] with x0 <= x1, y0 <= y1, z0 <= z1");
    if (f.heightRange)
        need(std::isfinite((*f.heightRange)[0]) && std::isfinite((*f.heightRange)[1]),
             "effects.fog.height_range must be finite");
    if (!f.heightMap.empty()) {
        int axes = 0;
        for (double c : f.up)
            axes += c != 0.0 ? 1 : 0;
        need(axes == 1, "effects.fog.height_map needs effects.fog.up along a coordinate axis");
    }
}
} // namespace

void Scene::validate() const {
    auto need = [](bool ok, const std::string& msg) {
        if (!ok) throw UsageError("scene: " + msg);
    };
    need(width >= 1 && height >= 1 && width <= 16384 && height <= 16384,
         "image size " + std::to_string(width) + "x" + std::to_string(height) + " must be 1..16384 per side");
    // The channel renderer has no label kernel, and labels colour one intensity volume, not a blend.
    need(!(labels && multiChannel()),
         "labels are drawn over a single-channel volume, not with \"channels\" or "
         "direct colour");
    // Lengths reach the kernels as float: 1e30 leaves headroom below float's 3.4e38.
    need(std::isfinite(step) && step > 0.0 && step <= 1e30, "render.step must be in (0, 1e30]");
    need(!stepVoxels || (std::isfinite(*stepVoxels) && *stepVoxels > 0.0 && *stepVoxels <= 1e30),
         "render.step in voxels must be in (0, 1e30]");
    need(earlyTermination > 0.0 && earlyTermination <= 1.0, "render.early_termination must be in (0, 1]");
    need(tableSize >= 2 && tableSize <= 4096, "render.table_size must be 2..4096");
    need(tableLengths >= 1 && tableLengths <= 1024, "render.table_lengths must be 1..1024");
    // The table's entries are nodes^2 x lengths, each integrated over the TF's pieces: the same budget as
    // `volcl preint` (kMaxTableEntries), checked before the table is allocated.
    if (preintegration == Preintegration::Table3d)
        need(double(tableSize) * tableSize * tableLengths <= double(kMaxTableEntries),
             "render.table_size " + std::to_string(tableSize) + " x render.table_lengths " +
                 std::to_string(tableLengths) + " is " +
                 std::to_string(std::int64_t(tableSize) * tableSize * tableLengths) +
                 " table entries, more than the budget of 2^24 (" + std::to_string(kMaxTableEntries) + ")");
    need(kBufferDepth >= 2 && kBufferDepth <= 8, "render.k must be 2..8");
    // 8 voxels: the smoothing's 3-sigma kernel stays at 49 taps (render/grid/BsplineField.hpp).
    need(smoothing >= 0.0 && smoothing <= 8.0, "render.smoothing must be in [0, 8] voxels");
    need(budgetMs >= 0.0 && budgetMs <= 1e9, "render.budget_ms must be in [0, 1e9] (0: no budget)");
    need(std::isfinite(lodError) && lodError >= 0.0, "render.lod_error must be finite and >= 0");
    need(std::isfinite(cacheMb) && cacheMb > 0.0 && cacheMb <= 1e7, "render.cache_mb must be in (0, 1e7]");
    need(!refineBricks || *refineBricks >= 1, "--refine-bricks must be at least 1");
    if (window)
        need(std::isfinite((*window)[0]) && std::isfinite((*window)[1]) && (*window)[1] > 0.0 &&
                 (*window)[1] <= 1e30 && std::abs((*window)[0]) <= 1e30,
             "render.window must be [centre, width] with width > 0 (finite, at most 1e30)");
    for (double b : background)
        need(b >= 0.0 && b <= 1.0, "image.background values must be in [0, 1]");
    for (double c : nanColor)
        need(c >= 0.0 && c <= 1.0, "render.nan_color values must be in [0, 1] (r, g, b, opacity)");
    // A partial camera's given fields are checked here; the rest once it is completed against the box.
    if (camera) {
        const Vec3 f = sub(camera->target, camera->eye);
        if (cameraGiven.eye && cameraGiven.target) {
            need(norm(f) > 0.0, "camera.eye and camera.target coincide");
            if (cameraGiven.up)
                need(norm(cross(f, camera->up)) > 1e-12 * norm(f) * norm(camera->up),
                     "camera.up is parallel to the view");
        }
        if (camera->projection == Projection::Orthographic && cameraGiven.height)
            need(camera->height > 0.0, "camera.height must be > 0");
        else
            need(camera->fovYDeg > 0.0 && camera->fovYDeg < 180.0, "camera.fov_y_deg must be in (0, 180)");
    }
    need(lights.size() <= 4, "at most 4 lights");
    for (const auto& l : lights) {
        need(l.intensity >= 0.0, "light intensity must be >= 0");
        if (l.kind == LightKind::Directional) need(norm(l.vector) > 0.0, "light direction must be non-zero");
        for (double c : l.color)
            need(c >= 0.0, "light colour must be >= 0");
    }
    const SceneEffects& e = effects;
    need(e.ambient >= 0 && e.diffuse >= 0 && e.specular >= 0 && e.shininess >= 0,
         "shading coefficients must be >= 0");
    need(std::isfinite(e.shadowStep) && e.shadowStep >= 0.0 && e.shadowStep <= 1e30,
         "effects.shadow_step must be 0 (the render step) or in (0, 1e30]");
    need(e.lightVolumeCell >= 1 && e.lightVolumeCell <= 64, "effects.light_volume_cell must be in [1, 64]");
    need(e.headLightToleranceDeg >= 0.0 && e.headLightToleranceDeg <= 90.0,
         "effects.shadow_head_tolerance must be in [0, 90] degrees");
    need(e.albedo >= 0.0 && e.albedo <= 1.0, "effects.scattering.albedo must be in [0, 1]");
    need(e.phaseG > -1.0 && e.phaseG < 1.0, "effects.scattering.g must be in (-1, 1)");
    need(e.samples >= 1 && e.samples <= (1 << 20), "effects.scattering.samples must be in [1, 1048576]");
    need(e.maxBounces >= 1 && e.maxBounces <= 4096, "effects.scattering.bounces must be in [1, 4096]");
    need(e.octaves >= 0 && e.octaves <= 8, "effects.scattering.octaves must be in [0, 8]");
    for (double c : e.environment)
        need(std::isfinite(c) && c >= 0.0, "effects.scattering.environment must be finite and >= 0");
    const std::size_t planes = e.clipPlanes.size() + (e.cropBox ? kCropBoxPlanes : 0);
    need(planes <= kMaxClipPlanes,
         "at most " + std::to_string(kMaxClipPlanes) + " clipping planes, a crop box counting " +
             std::to_string(kCropBoxPlanes) + " (got " + std::to_string(planes) + ")");
    if (e.cropBox)
        for (int a = 0; a < 3; ++a)
            need(std::isfinite(e.cropBox->lo[a]) && std::isfinite(e.cropBox->hi[a]) &&
                     e.cropBox->lo[a] <= e.cropBox->hi[a],
                 "effects.crop_box must be [[x0, y0, z0], [x1, y1, z1]] with x0 <= x1, y0 <= y1, z0 <= z1 "
                 "(finite)");
    for (const auto& p : e.clipPlanes)
        need(norm(p.normal) > 0.0, "clipping plane normal must be non-zero");
    need(e.isosurfaces.size() <= 4, "at most 4 iso-surfaces");
    for (const auto& i : e.isosurfaces)
        for (double c : i.rgba)
            need(c >= 0.0 && c <= 1.0, "iso-surface colour values must be in [0, 1]");
    if (mode == RenderMode::Iso) need(!e.isosurfaces.empty(), "mode iso needs effects.isosurfaces");
    if (e.fog.enabled) validateFog(e.fog);
}

std::vector<std::string> applyLightingDefaults(Scene& scene) {
    std::vector<std::string> notes;
    SceneEffects& fx = scene.effects;
    if (scene.mode == RenderMode::Iso && !fx.shadingGiven && !fx.shading) {
        fx.shading = true;
        notes.push_back("iso mode: shading on (Blinn-Phong ambient " +
                        std::to_string(fx.ambient).substr(0, 4) + ", diffuse " +
                        std::to_string(fx.diffuse).substr(0, 4) + "); --no-shading turns it off");
    }
    const bool marching = scene.mode == RenderMode::Dvr || scene.mode == RenderMode::Iso;
    const bool wantsLight = fx.shading || fx.shadows || (fx.scattering && fx.albedo > 0.0);
    bool lit = false;
    for (const auto& l : scene.lights)
        lit = lit || (l.intensity > 0.0 && (l.color[0] > 0.0 || l.color[1] > 0.0 || l.color[2] > 0.0));
    if (marching && wantsLight && !lit && scene.lights.empty()) {
        Light head;
        head.kind = LightKind::Head;
        scene.lights.push_back(head);
        notes.push_back("no light given: using a head light (at the eye, intensity 1); --light sets others");
    }
    return notes;
}

namespace {
std::string shortNumber(double v) {
    std::ostringstream s;
    s << v;
    return s.str();
}
} // namespace

StepSpec parseStepSpec(const std::string& text, const std::string& what) {
    StepSpec out;
    std::string number = text;
    if (number.size() > 3 && number.compare(number.size() - 3, 3, "vox") == 0) {
        out.voxels = true;
        number.resize(number.size() - 3);
    }
    std::size_t used = 0;
    try {
        out.value = std::stod(number, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used == 0 || used != number.size() || !std::isfinite(out.value) || !(out.value > 0.0))
        throw UsageError(what + " '" + text +
                         "' is not a step: a number > 0 in world units (0.01) or voxels (0.5vox)");
    return out;
}

CropBox parseCropBoxSpec(const std::string& text, const std::string& what) {
    const std::string form =
        " must be x0,y0,z0:x1,y1,z1 (world units) or x0,y0,z0:x1,y1,z1vox (voxel indices)";
    CropBox box;
    std::string body = text;
    if (body.size() > 3 && body.compare(body.size() - 3, 3, "vox") == 0) {
        box.voxels = true;
        body.resize(body.size() - 3);
    }
    const std::size_t colon = body.find(':');
    if (colon == std::string::npos || body.find(':', colon + 1) != std::string::npos)
        throw UsageError(what + " '" + text + "'" + form);
    auto corner = [&](const std::string& part) {
        Vec3 v{};
        std::size_t at = 0;
        for (int a = 0; a < 3; ++a) {
            const std::size_t comma = a < 2 ? part.find(',', at) : part.size();
            if (comma == std::string::npos) throw UsageError(what + " '" + text + "'" + form);
            const std::string item = part.substr(at, comma - at);
            std::size_t used = 0;
            try {
                v[a] = std::stod(item, &used);
            } catch (const std::exception&) {
                used = 0;
            }
            if (used == 0 || used != item.size() || !std::isfinite(v[a]))
                throw UsageError(what + " '" + text + "'" + form);
            at = comma + 1;
        }
        return v;
    };
    box.lo = corner(body.substr(0, colon));
    box.hi = corner(body.substr(colon + 1));
    for (int a = 0; a < 3; ++a)
        if (box.lo[a] > box.hi[a])
            throw UsageError(what + " '" + text +
                             "' is inverted: x0 <= x1, y0 <= y1 and z0 <= z1 are needed");
    return box;
}

std::string resolveCropBox(Scene& scene, const Vec3& origin, const Vec3& spacing) {
    if (!scene.effects.cropBox || !scene.effects.cropBox->voxels) return {};
    CropBox& box = *scene.effects.cropBox;
    for (int a = 0; a < 3; ++a) {
        box.lo[a] = origin[a] + spacing[a] * box.lo[a];
        box.hi[a] = origin[a] + spacing[a] * box.hi[a];
    }
    box.voxels = false;
    return "crop box in world units: " + shortNumber(box.lo[0]) + "," + shortNumber(box.lo[1]) + "," +
           shortNumber(box.lo[2]) + ":" + shortNumber(box.hi[0]) + "," + shortNumber(box.hi[1]) + "," +
           shortNumber(box.hi[2]);
}

std::vector<ClipPlane> cropBoxPlanes(const CropBox& box) {
    std::vector<ClipPlane> planes;
    for (int a = 0; a < 3; ++a) {
        Vec3 n{0, 0, 0};
        n[a] = 1.0;
        planes.push_back({n, -box.lo[a]}); // x_a - lo >= 0
        n[a] = -1.0;
        planes.push_back({n, box.hi[a]}); // hi - x_a >= 0
    }
    return planes;
}

std::vector<ClipPlane> activeClipPlanes(const SceneEffects& effects) {
    std::vector<ClipPlane> planes = effects.clipPlanes;
    if (!effects.cropBox) return planes;
    if (effects.cropBox->voxels)
        throw UsageError("effects.crop_box in voxels needs a grid's spacing: render it through its input "
                         "(RenderInput), or give the box in world units");
    for (const ClipPlane& p : cropBoxPlanes(*effects.cropBox))
        planes.push_back(p);
    return planes;
}

std::string resolveStep(Scene& scene, double cellLength) {
    if (!scene.stepVoxels) return {};
    if (!(std::isfinite(cellLength) && cellLength > 0.0))
        throw UsageError("render.step " + shortNumber(*scene.stepVoxels) +
                         "vox: the input has no cell size (give the step in world units)");
    scene.step = *scene.stepVoxels * cellLength;
    const std::string note = "step: " + shortNumber(*scene.stepVoxels) + " voxel of the cell size " +
                             shortNumber(cellLength) + " = " + shortNumber(scene.step) +
                             " world units (--step D sets world units, --step Nvox voxels)";
    scene.stepVoxels.reset();
    return note;
}

void Scene::validateSteps(double worldDiagonal) const {
    // Guard against steps so small that one ray would take longer than any frame should.
    constexpr double kMaxSamplesPerRay = 5e7;
    auto check = [&](double value, const char* field) {
        if (worldDiagonal / value > kMaxSamplesPerRay)
            throw UsageError(std::string(field) + " " + shortNumber(value) + " needs " +
                             shortNumber(std::ceil(worldDiagonal / value)) +
                             " samples per ray; use a step of at least " +
                             shortNumber(worldDiagonal / kMaxSamplesPerRay));
    };
    check(step, "render.step");
    if (effects.shadowStep > 0.0) check(effects.shadowStep, "effects.shadow_step");
    // The frame's worst case: every pixel marches the whole diagonal, and with shadows every sample marches
    // it again toward each light. Early termination and skipping only lower the real count.
    const double perRay = std::ceil(worldDiagonal / step);
    const double shadowStepLength = effects.shadowStep > 0.0 ? effects.shadowStep : step;
    const double lightCount = double(std::max<std::size_t>(lights.size(), 1));
    const double perSample =
        effects.shadows ? 1.0 + lightCount * std::ceil(worldDiagonal / shadowStepLength) : 1.0;
    const double samples = double(width) * double(height) * perRay * perSample;
    if (samples > kMaxSamplesPerFrame)
        throw UsageError(
            std::string(effects.shadows ? "render.step and effects.shadow_step" : "render.step") + " on a " +
            std::to_string(width) + "x" + std::to_string(height) + " image " +
            (effects.shadows ? "need " : "needs ") + shortNumber(samples) +
            " samples per frame, more than the budget of " + shortNumber(kMaxSamplesPerFrame) +
            "; use a larger step or a smaller image");
}

Camera defaultCamera(const WorldBox& box) {
    const Vec3 lo = box.origin, ext = box.extent;
    const Vec3 centre = add(lo, scale(ext, 0.5));
    const double diag = std::max(norm(ext), 1.0);
    Camera c;
    c.projection = Projection::Orthographic;
    c.target = centre;
    c.eye = sub(centre, Vec3{0, 0, 2.0 * diag});
    c.up = {0, 1, 0};
    c.height = std::max({ext[0], ext[1], 1.0}) * 1.05;
    return c;
}

CameraRay cameraRay(const Camera& cam, int width, int height, double x, double y) {
    const Vec3 f = normalized(sub(cam.target, cam.eye));
    const Vec3 r0 = normalized(cross(f, cam.up));
    const Vec3 u = cross(r0, f);
    const Vec3 r = cam.mirrored ? scale(r0, -1.0) : r0;
    const double ndcX = 2.0 * (x + 0.5) / width - 1.0;
    const double ndcY = 1.0 - 2.0 * (y + 0.5) / height;
    const double aspect = double(width) / double(height);
    CameraRay ray;
    if (cam.projection == Projection::Orthographic) {
        const double h = cam.height / 2.0;
        ray.origin = add(cam.eye, add(scale(r, ndcX * h * aspect), scale(u, ndcY * h)));
        ray.direction = f;
    } else {
        const double t = std::tan(cam.fovYDeg * 3.14159265358979323846 / 360.0);
        ray.origin = cam.eye;
        ray.direction = normalized(add(f, add(scale(r, ndcX * t * aspect), scale(u, ndcY * t))));
    }
    return ray;
}

} // namespace volcl
