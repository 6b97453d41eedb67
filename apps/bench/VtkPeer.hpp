// What the VTK peer scripts (bench/vtk_raycast.py, bench/vtk_mesh.py) are given, how they run and what they
// give back: shared by `volcl bench render` on grids and on meshes.
#pragma once

#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>

namespace volcl::cli {

/// The TF densely sampled (1024 rows of value, r, g, b, opacity of a unit length): VTK interpolates opacity
/// linearly, ours is linear in optical depth.
nlohmann::json vtkTransferFunction(const TransferFunction& tf);

/// The camera as the scripts read it: eye, target, up, height, perspective, fov_y_deg.
nlohmann::json vtkCamera(const Camera& cam);

/// Blinn-Phong as bench/vtk_raycast.py applies it (ShadeOn, VTK's head light): ambient, diffuse, specular and
/// specular_power of a scene that shades with one head light; null for an unshaded scene. Throws UsageError
/// for other lights (the peer has only its head light).
nlohmann::json vtkShading(const Scene& scene);

/// Runs `script` on the job file under xvfb-run with the system python3; Error naming the command when it
/// fails (python3-vtk9 missing, most often).
void runVtkScript(const std::string& script, const std::filesystem::path& job);

/// A peer's image: `width` x `height` RGBA float32 pixels, raw; IoError when the file has another size.
ImageBuffer readVtkImage(const std::filesystem::path& raw, int width, int height);

} // namespace volcl::cli
