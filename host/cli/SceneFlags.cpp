// Command-line flags that build or override a Scene (see SceneFlags.hpp).
#include "host/cli/SceneFlags.hpp"

#include "host/Error.hpp"

#include <sstream>
#include <stdexcept>

namespace volcl::cli {

std::vector<double> parseNumbers(const std::string& text, std::size_t count, const std::string& what) {
    std::vector<double> out;
    std::stringstream ss(text);
    std::string item;
    while (std::getline(ss, item, ',')) {
        try {
            std::size_t used = 0;
            out.push_back(std::stod(item, &used));
            if (used != item.size()) throw std::invalid_argument(item);
        } catch (const std::exception&) {
            throw UsageError(what + ": '" + item + "' is not a number");
        }
    }
    if (count && out.size() != count)
        throw UsageError(what + ": expected " + std::to_string(count) + " comma-separated numbers, got '" +
                         text + "'");
    return out;
}

Vec3 parseVec3(const std::string& text, const std::string& what) {
    const auto v = parseNumbers(text, 3, what);
    return {v[0], v[1], v[2]};
}

void SceneFlags::add(CLI::App* cmd) {
    cmd->add_option("--scene", scene, "Scene JSON (CONTRACT section 4); flags below override its fields");
    cmd->add_option("--volume", volume, "Volume file (overrides the scene's)");
    cmd->add_option("--tf", tf, "Transfer function: canonical/ParaView JSON or an RGBA strip image");
    cmd->add_option("--mode", mode, "dvr, mip, iso or xray");
    cmd->add_option("--step", step, "Sampling distance in world units");
    cmd->add_option("--preintegration", preint, "none, 2d or 3d (dvr only)");
    cmd->add_option("--width", width, "Image width in pixels");
    cmd->add_option("--height", height, "Image height in pixels");
    cmd->add_option("--projection", projection, "orthographic or perspective");
    cmd->add_option("--eye", eye, "Camera position x,y,z");
    cmd->add_option("--target", target, "Camera target x,y,z");
    cmd->add_option("--up", up, "Camera up vector x,y,z");
    cmd->add_option("--view-height", viewHeight, "Orthographic view height in world units");
    cmd->add_option("--fov", fov, "Perspective vertical field of view in degrees");
    cmd->add_option("--background", background, "PNG background r,g,b,a (straight, linear)");
    cmd->add_option("--early-termination", earlyTermination, "Stop rays at this opacity (1 = never)");
    cmd->add_flag("--no-skipping", noSkipping, "Disable empty-space skipping");
    cmd->add_option("--table-size", tableSize, "Pre-integration table nodes");
    cmd->add_option("--table-lengths", tableLengths, "3D pre-integration: number of lengths");
    cmd->add_option("--iso", isos, "Iso-surface value[:r,g,b,a] (repeatable)");
    cmd->add_option("--light", lights,
                    "Light: head | dir:x,y,z | point:x,y,z, optionally @intensity (repeatable)");
    cmd->add_option("--shading", shading, "Blinn-Phong ambient,diffuse,specular,shininess");
    cmd->add_flag("--sobel", sobel, "Sobel gradients instead of central differences");
    cmd->add_flag("--shadows", shadows, "Shadows by secondary marching toward each light");
    cmd->add_option("--shadow-step", shadowStep, "Shadow ray step in world units");
    cmd->add_option("--scattering", scattering, "Single scattering albedo,g (Henyey-Greenstein)");
    cmd->add_option("--clip", clips,
                    "Clipping plane nx,ny,nz,offset keeping n.x + offset >= 0 (repeatable)");
    raw.add(*cmd);
}

Scene SceneFlags::build(bool requireTf) const {
    Scene s = scene.empty() ? Scene{} : Scene::fromFile(scene);
    if (!volume.empty()) s.volume = volume;
    if (!tf.empty()) s.tf = tf;
    if (!mode.empty()) s.mode = parseRenderMode(mode);
    if (step) s.step = *step;
    if (!preint.empty()) s.preintegration = parsePreintegration(preint);
    if (width) s.width = *width;
    if (height) s.height = *height;
    if (earlyTermination) s.earlyTermination = *earlyTermination;
    if (noSkipping) s.skipping = false;
    if (tableSize) s.tableSize = *tableSize;
    if (tableLengths) s.tableLengths = *tableLengths;
    if (!background.empty()) {
        const auto b = parseNumbers(background, 4, "--background");
        s.background = {b[0], b[1], b[2], b[3]};
    }
    const bool cameraFlag =
        !projection.empty() || !eye.empty() || !target.empty() || !up.empty() || viewHeight || fov;
    if (cameraFlag) {
        Camera c = s.camera ? *s.camera : Camera{};
        if (!s.camera && (eye.empty() || target.empty()))
            throw UsageError("--eye and --target are needed when the scene has no camera");
        if (!projection.empty()) {
            if (projection == "orthographic")
                c.projection = Projection::Orthographic;
            else if (projection == "perspective")
                c.projection = Projection::Perspective;
            else
                throw UsageError("--projection '" + projection +
                                 "' is unknown (orthographic, perspective)");
        } else if (fov) {
            c.projection = Projection::Perspective;
        }
        if (!eye.empty()) c.eye = parseVec3(eye, "--eye");
        if (!target.empty()) c.target = parseVec3(target, "--target");
        if (!up.empty()) c.up = parseVec3(up, "--up");
        if (viewHeight) c.height = *viewHeight;
        if (fov) c.fovYDeg = *fov;
        s.camera = c;
    }
    for (const auto& text : isos) {
        IsoLayer iso;
        const auto colon = text.find(':');
        iso.value = parseNumbers(text.substr(0, colon), 1, "--iso")[0];
        if (colon != std::string::npos) {
            const auto c = parseNumbers(text.substr(colon + 1), 4, "--iso colour");
            iso.rgba = {c[0], c[1], c[2], c[3]};
        }
        s.effects.isosurfaces.push_back(iso);
    }
    for (const auto& text : lights) {
        Light l;
        std::string spec = text;
        const auto at = spec.find('@');
        if (at != std::string::npos) {
            l.intensity = parseNumbers(spec.substr(at + 1), 1, "--light intensity")[0];
            spec = spec.substr(0, at);
        }
        if (spec == "head")
            l.kind = LightKind::Head;
        else if (spec.rfind("dir:", 0) == 0) {
            l.kind = LightKind::Directional;
            l.vector = parseVec3(spec.substr(4), "--light dir");
        } else if (spec.rfind("point:", 0) == 0) {
            l.kind = LightKind::Point;
            l.vector = parseVec3(spec.substr(6), "--light point");
        } else {
            throw UsageError("--light '" + text + "' is not head, dir:x,y,z or point:x,y,z");
        }
        s.lights.push_back(l);
    }
    if (!shading.empty()) {
        const auto v = parseNumbers(shading, 4, "--shading");
        s.effects.shading = true;
        s.effects.ambient = v[0];
        s.effects.diffuse = v[1];
        s.effects.specular = v[2];
        s.effects.shininess = v[3];
    }
    if (sobel) s.effects.gradient = GradientKind::Sobel;
    if (shadows) s.effects.shadows = true;
    if (shadowStep) s.effects.shadowStep = *shadowStep;
    if (!scattering.empty()) {
        const auto v = parseNumbers(scattering, 2, "--scattering");
        s.effects.scattering = true;
        s.effects.albedo = v[0];
        s.effects.phaseG = v[1];
    }
    for (const auto& text : clips) {
        const auto v = parseNumbers(text, 4, "--clip");
        s.effects.clipPlanes.push_back({{v[0], v[1], v[2]}, v[3]});
    }
    if (s.volume.empty()) throw UsageError("no volume: give --volume or a scene with \"volume\"");
    if (requireTf && s.tf.empty()) throw UsageError("no transfer function: give --tf or a scene with \"tf\"");
    s.validate();
    return s;
}

} // namespace volcl::cli
