// Scene JSON parsing and validation, lighting defaults, default camera, and the double-precision camera
// rays (docs/contract.md, "Scenes and images").
#include "host/render/Scene.hpp"

#include "host/Error.hpp"
#include "host/render/VecMath.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace volcl {
namespace {

using nlohmann::json;

json parse(std::string_view text) {
    try {
        return json::parse(text.begin(), text.end());
    } catch (const json::parse_error& e) {
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
    }
    return "dvr";
}

RenderMode parseRenderMode(std::string_view s) {
    if (s == "dvr") return RenderMode::Dvr;
    if (s == "mip") return RenderMode::Mip;
    if (s == "iso") return RenderMode::Iso;
    if (s == "xray") return RenderMode::Xray;
    throw UsageError("render mode '" + std::string(s) + "' is unknown (expected dvr, mip, iso, xray)");
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

std::string_view meshMethodName(MeshMethod m) {
    return m == MeshMethod::KBuffer ? "kbuffer" : "cells";
}

MeshMethod parseMeshMethod(std::string_view s) {
    if (s == "cells") return MeshMethod::Cells;
    if (s == "kbuffer") return MeshMethod::KBuffer;
    throw UsageError("render.method '" + std::string(s) + "' is unknown (expected cells, kbuffer)");
}

Scene Scene::fromJson(std::string_view text, const std::filesystem::path& baseDir) {
    const json j = parse(text);
    checkKeys(j, "the scene", {"volume", "tf", "camera", "image", "render", "lights", "effects"});
    Scene s;
    auto path = [&](const json& v, const char* where) {
        std::filesystem::path p(str(v, where));
        return p.is_relative() && !baseDir.empty() ? baseDir / p : p;
    };
    if (j.contains("volume")) s.volume = path(j["volume"], "volume");
    if (j.contains("tf")) s.tf = path(j["tf"], "tf");
    if (j.contains("camera")) {
        const json& c = j["camera"];
        checkKeys(c, "camera", {"projection", "eye", "target", "up", "height", "fov_y_deg"});
        Camera cam;
        if (c.contains("projection")) {
            const std::string p = str(c["projection"], "camera.projection");
            if (p == "orthographic")
                cam.projection = Projection::Orthographic;
            else if (p == "perspective")
                cam.projection = Projection::Perspective;
            else
                throw UsageError("scene: camera.projection '" + p +
                                 "' is unknown (orthographic, perspective)");
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
    if (j.contains("image")) {
        const json& im = j["image"];
        checkKeys(im, "image", {"width", "height", "background"});
        if (im.contains("width")) s.width = static_cast<int>(num(im["width"], "image.width"));
        if (im.contains("height")) s.height = static_cast<int>(num(im["height"], "image.height"));
        if (im.contains("background")) s.background = vec<4>(im["background"], "image.background");
    }
    if (j.contains("render")) {
        const json& r = j["render"];
        checkKeys(r, "render",
                  {"mode", "step", "preintegration", "early_termination", "skipping", "table_size",
                   "table_lengths", "filter", "smoothing", "window", "mip_color", "method", "k"});
        if (r.contains("mode")) s.mode = parseRenderMode(str(r["mode"], "render.mode"));
        if (r.contains("step")) s.step = num(r["step"], "render.step");
        if (r.contains("preintegration")) {
            const json& p = r["preintegration"];
            s.preintegration = p.is_boolean()
                                   ? (p.get<bool>() ? Preintegration::Table2d : Preintegration::None)
                                   : parsePreintegration(str(p, "render.preintegration"));
        }
        if (r.contains("early_termination"))
            s.earlyTermination = num(r["early_termination"], "render.early_termination");
        if (r.contains("skipping")) s.skipping = flag(r["skipping"], "render.skipping");
        if (r.contains("table_size"))
            s.tableSize = static_cast<int>(num(r["table_size"], "render.table_size"));
        if (r.contains("table_lengths"))
            s.tableLengths = static_cast<int>(num(r["table_lengths"], "render.table_lengths"));
        if (r.contains("filter")) s.filter = parseFilter(str(r["filter"], "render.filter"));
        if (r.contains("smoothing")) s.smoothing = num(r["smoothing"], "render.smoothing");
        if (r.contains("window")) s.window = vec<2>(r["window"], "render.window");
        if (r.contains("mip_color")) s.mipColor = parseMipColor(str(r["mip_color"], "render.mip_color"));
        if (r.contains("method")) s.meshMethod = parseMeshMethod(str(r["method"], "render.method"));
        if (r.contains("k")) s.kBufferDepth = static_cast<int>(num(r["k"], "render.k"));
    }
    if (j.contains("lights")) {
        if (!j["lights"].is_array()) throw UsageError("scene: 'lights' must be an array");
        int i = 0;
        for (const json& l : j["lights"]) {
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
    if (j.contains("effects")) {
        const json& e = j["effects"];
        checkKeys(
            e, "effects",
            {"shading", "gradient", "shadows", "shadow_step", "scattering", "clip_planes", "isosurfaces"});
        SceneEffects& fx = s.effects;
        if (e.contains("shading")) {
            fx.shadingGiven = true;
            const json& sh = e["shading"];
            if (sh.is_boolean()) {
                fx.shading = sh.get<bool>();
            } else {
                checkKeys(sh, "effects.shading", {"ambient", "diffuse", "specular", "shininess"});
                fx.shading = true;
                if (sh.contains("ambient")) fx.ambient = num(sh["ambient"], "effects.shading.ambient");
                if (sh.contains("diffuse")) fx.diffuse = num(sh["diffuse"], "effects.shading.diffuse");
                if (sh.contains("specular")) fx.specular = num(sh["specular"], "effects.shading.specular");
                if (sh.contains("shininess"))
                    fx.shininess = num(sh["shininess"], "effects.shading.shininess");
            }
        }
        if (e.contains("gradient")) {
            const std::string g = str(e["gradient"], "effects.gradient");
            if (g == "central")
                fx.gradient = GradientKind::Central;
            else if (g == "sobel")
                fx.gradient = GradientKind::Sobel;
            else
                throw UsageError("scene: effects.gradient '" + g + "' is unknown (central, sobel)");
        }
        if (e.contains("shadows")) fx.shadows = flag(e["shadows"], "effects.shadows");
        if (e.contains("shadow_step")) fx.shadowStep = num(e["shadow_step"], "effects.shadow_step");
        if (e.contains("scattering")) {
            const json& sc = e["scattering"];
            checkKeys(sc, "effects.scattering", {"albedo", "g"});
            fx.scattering = true;
            if (sc.contains("albedo")) fx.albedo = num(sc["albedo"], "effects.scattering.albedo");
            if (sc.contains("g")) fx.phaseG = num(sc["g"], "effects.scattering.g");
        }
        if (e.contains("clip_planes")) {
            if (!e["clip_planes"].is_array())
                throw UsageError("scene: 'effects.clip_planes' must be an array");
            int i = 0;
            for (const json& p : e["clip_planes"]) {
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
        if (e.contains("isosurfaces")) {
            if (!e["isosurfaces"].is_array())
                throw UsageError("scene: 'effects.isosurfaces' must be an array");
            int i = 0;
            for (const json& p : e["isosurfaces"]) {
                const std::string where = "effects.isosurfaces[" + std::to_string(i++) + "]";
                checkKeys(p, where, {"value", "color"});
                IsoLayer iso;
                if (!p.contains("value")) throw UsageError("scene: " + where + " needs 'value'");
                iso.value = num(p["value"], where + ".value");
                if (p.contains("color")) iso.rgba = vec<4>(p["color"], where + ".color");
                fx.isosurfaces.push_back(iso);
            }
        }
    }
    return s;
}

Scene Scene::fromFile(const std::filesystem::path& path) {
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
                   {"step", step},
                   {"preintegration", std::string(preintegrationName(preintegration))},
                   {"early_termination", earlyTermination},
                   {"skipping", skipping},
                   {"table_size", tableSize},
                   {"table_lengths", tableLengths},
                   {"filter", std::string(filterName(filter))},
                   {"smoothing", smoothing},
                   {"mip_color", std::string(mipColorName(mipColor))}};
    // Mesh fields only when set (grid scenes' JSON stays as it was).
    if (meshMethod != MeshMethod::Cells) j["render"]["method"] = std::string(meshMethodName(meshMethod));
    if (kBufferDepth != 6) j["render"]["k"] = kBufferDepth;
    if (window) j["render"]["window"] = *window;
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
    if (effects.shading)
        e["shading"] = {{"ambient", effects.ambient},
                        {"diffuse", effects.diffuse},
                        {"specular", effects.specular},
                        {"shininess", effects.shininess}};
    e["gradient"] = effects.gradient == GradientKind::Sobel ? "sobel" : "central";
    if (effects.shadows) e["shadows"] = true;
    e["shadow_step"] = effects.shadowStep;
    if (effects.scattering) e["scattering"] = {{"albedo", effects.albedo}, {"g", effects.phaseG}};
    if (!effects.clipPlanes.empty()) {
        e["clip_planes"] = json::array();
        for (const auto& p : effects.clipPlanes)
            e["clip_planes"].push_back({{"normal", p.normal}, {"offset", p.offset}});
    }
    if (!effects.isosurfaces.empty()) {
        e["isosurfaces"] = json::array();
        for (const auto& i : effects.isosurfaces)
            e["isosurfaces"].push_back({{"value", i.value}, {"color", i.rgba}});
    }
    j["effects"] = e;
    return j.dump(2);
}

void Scene::validate() const {
    auto need = [](bool ok, const std::string& msg) {
        if (!ok) throw UsageError("scene: " + msg);
    };
    need(width >= 1 && height >= 1 && width <= 16384 && height <= 16384,
         "image size " + std::to_string(width) + "x" + std::to_string(height) + " must be 1..16384 per side");
    // Lengths reach the kernels as float: 1e30 leaves headroom below float's 3.4e38.
    need(std::isfinite(step) && step > 0.0 && step <= 1e30, "render.step must be in (0, 1e30]");
    need(earlyTermination > 0.0 && earlyTermination <= 1.0, "render.early_termination must be in (0, 1]");
    need(tableSize >= 2 && tableSize <= 4096, "render.table_size must be 2..4096");
    need(tableLengths >= 1 && tableLengths <= 1024, "render.table_lengths must be 1..1024");
    need(kBufferDepth >= 2 && kBufferDepth <= 8, "render.k must be 2..8");
    // 8 voxels: the smoothing's 3-sigma kernel stays at 49 taps (host/render/grid/BsplineField.hpp).
    need(smoothing >= 0.0 && smoothing <= 8.0, "render.smoothing must be in [0, 8] voxels");
    if (window)
        need(std::isfinite((*window)[0]) && std::isfinite((*window)[1]) && (*window)[1] > 0.0 &&
                 (*window)[1] <= 1e30 && std::abs((*window)[0]) <= 1e30,
             "render.window must be [centre, width] with width > 0 (finite, at most 1e30)");
    for (double b : background)
        need(b >= 0.0 && b <= 1.0, "image.background values must be in [0, 1]");
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
    need(e.albedo >= 0.0 && e.albedo <= 1.0, "effects.scattering.albedo must be in [0, 1]");
    need(e.phaseG > -1.0 && e.phaseG < 1.0, "effects.scattering.g must be in (-1, 1)");
    need(e.clipPlanes.size() <= 4, "at most 4 clipping planes");
    for (const auto& p : e.clipPlanes)
        need(norm(p.normal) > 0.0, "clipping plane normal must be non-zero");
    need(e.isosurfaces.size() <= 4, "at most 4 iso-surfaces");
    for (const auto& i : e.isosurfaces)
        for (double c : i.rgba)
            need(c >= 0.0 && c <= 1.0, "iso-surface colour values must be in [0, 1]");
    if (mode == RenderMode::Iso) need(!e.isosurfaces.empty(), "mode iso needs effects.isosurfaces");
}

std::vector<std::string> applyLightingDefaults(Scene& scene) {
    std::vector<std::string> notes;
    SceneEffects& fx = scene.effects;
    if (scene.mode == RenderMode::Iso && !fx.shadingGiven && !fx.shading) {
        fx.shading = true;
        notes.push_back("iso mode: shading on (Blinn-Phong ambient " + std::to_string(fx.ambient).substr(0, 4) +
                        ", diffuse " + std::to_string(fx.diffuse).substr(0, 4) + "); --no-shading turns it off");
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
    const Vec3 r = normalized(cross(f, cam.up));
    const Vec3 u = cross(r, f);
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
