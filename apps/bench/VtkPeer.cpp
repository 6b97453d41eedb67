// What the VTK peer scripts (bench/vtk_raycast.py, bench/vtk_mesh.py) are given, how they run and what they
// give back.
#include "apps/bench/VtkPeer.hpp"

#include "apps/cli/CliParsing.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"

#include <cmath>
#include <cstdlib>
#include <cstring>

namespace volcl::cli {

nlohmann::json vtkTransferFunction(const TransferFunction& tf) {
    nlohmann::json samples = nlohmann::json::array();
    const int n = 1024;
    for (int i = 0; i < n; ++i) {
        const double x = tf.domain[0] + (tf.domain[1] - tf.domain[0]) * i / (n - 1);
        const auto c = tf.colorAt(x);
        samples.push_back({x, c[0], c[1], c[2], 1.0 - std::exp(-tf.extinctionAt(x))});
    }
    return samples;
}

nlohmann::json vtkCamera(const Camera& cam) {
    return {{"eye", cam.eye},
            {"target", cam.target},
            {"up", cam.up},
            {"height", cam.height},
            {"perspective", cam.projection == Projection::Perspective},
            {"fov_y_deg", cam.fovYDeg}};
}

nlohmann::json vtkShading(const Scene& scene) {
    if (!scene.effects.shading || scene.lights.empty()) return nullptr;
    if (scene.lights.size() != 1 || scene.lights[0].kind != LightKind::Head ||
        scene.lights[0].intensity != 1.0 || scene.lights[0].color != Vec3{1, 1, 1})
        throw UsageError("bench render --vtk: the VTK peer shades with its white head light only (give one "
                         "head light of intensity 1)");
    const SceneEffects& e = scene.effects;
    return {{"ambient", e.ambient},
            {"diffuse", e.diffuse},
            {"specular", e.specular},
            {"specular_power", e.shininess}};
}

void runVtkScript(const std::string& script, const std::filesystem::path& job) {
    const std::string cmd =
        "xvfb-run -a /usr/bin/python3 " + shellQuote(script) + " " + shellQuote(job.string());
    if (std::system(cmd.c_str()) != 0)
        throw Error("VTK peer failed (" + cmd + "); is python3-vtk9 installed (scripts/apt-packages.txt)?");
}

ImageBuffer readVtkImage(const std::filesystem::path& raw, int width, int height) {
    const auto bytes = readFileBytes(raw);
    ImageBuffer img(width, height, {"R", "G", "B", "A"});
    if (bytes.size() != img.pixels.size() * sizeof(float)) throw IoError("VTK peer image has the wrong size");
    std::memcpy(img.pixels.data(), bytes.data(), bytes.size());
    return img;
}

} // namespace volcl::cli
