// Command-line flags that build or override a Scene: shared by `volcl render`, `bench render` and `view`.
#pragma once

#include "apps/cli/CliParsing.hpp"
#include "apps/cli/MeshInfo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <vector>

namespace volcl::cli {

/// Comma-separated numbers; `count` 0 accepts any number of them. Throws UsageError naming `what`.
std::vector<double> parseNumbers(const std::string& text, std::size_t count, const std::string& what);
/// "x,y,z" -> Vec3; throws UsageError naming `what`.
Vec3 parseVec3(const std::string& text, const std::string& what);

/// Scene fields a command line may override; empty means "keep the scene's value".
struct SceneFlags {
    std::string scene, volume, tf, mode, preint, projection, eye, target, up, background, nanColor;
    std::string view, orbit, tfRange, tfUnitDistance = "1";
    std::string filter, window, mipColor, lod, method;
    std::optional<double> lodError, cacheMb;
    std::optional<double> smoothing, step, viewHeight, fov, earlyTermination, shadowStep;
    std::optional<int> width, height, tableSize, tableLengths, k;
    std::optional<std::size_t> frame; ///< --frame K of a time series input
    bool noSkipping = false, sobel = false, shadows = false, noShading = false;
    std::string shading, scattering, scatteringOrder;
    std::optional<int> samples;
    std::vector<std::string> isos, lights, clips;
    RawReadFlags raw;
    std::string device; ///< OpenCL device selector for decoding a .vcz input whole (readSceneVolume)
    MeshReadFlags mesh; ///< --array, --q-var, --q for mesh inputs

    /// Registers every scene flag on `cmd`; the camera orbit flag is named `orbitFlag` (the viewer keeps
    /// `--orbit` for its per-frame turn).
    void add(CLI::App* cmd, const std::string& orbitFlag = "--orbit");
    /// The scene file (if any) with the flags applied, validated. Throws UsageError. `requireTf` false lets
    /// a scene without a transfer function through (the viewer then starts on a preset).
    Scene build(bool requireTf = true) const;
    /// The scene's volume: frame `--frame K` of a series (frame 0 when not given, with a note in `notes`
    /// when the input has more frames). Throws UsageError when K is out of range.
    /// `filesRead`, when given, receives every file the volume consists of (header and data files).
    Volume readSceneVolume(const Scene& s, std::vector<std::string>& notes,
                           std::vector<std::filesystem::path>* filesRead = nullptr) const;
    /// The scene's data as a renderer input: a tetrahedral mesh when the file is one (read with the mesh
    /// flags), else readSceneVolume()'s volume.
    RenderInput readSceneInput(const Scene& s, std::vector<std::string>& notes,
                               std::vector<std::filesystem::path>* filesRead = nullptr) const;
    /// finish() and loadTf() for any input (a mesh's box, value range and tet count).
    std::vector<std::string> finish(Scene& s, const RenderInput& in) const;
    TransferFunction loadTf(const Scene& s, const RenderInput& in) const;
    /// loadTf() with the data range given (a .vcz's from its index).
    TransferFunction loadTf(const Scene& s, const RenderInput& in, std::array<double, 2> dataRange) const;
    /// Once the volume is read: frames the camera the scene and flags leave incomplete (a named view,
    /// an orbit, a missing orthographic height or target, or the default view of anatomical data) and
    /// applies the lighting defaults. Returns one note per default applied (stderr and `--explain`).
    std::vector<std::string> finish(Scene& s, const Volume& v) const;
    /// The scene's transfer function as the render uses it: normalised presets spread over the data
    /// range, `--tf-range` applied, ParaView opacity per `--tf-unit-distance`.
    TransferFunction loadTf(const Scene& s, const Volume& v) const;
    /// As above with the data range given (a .vcz's index range, without scanning voxels); `v` supplies the
    /// grid's geometry only.
    TransferFunction loadTf(const Scene& s, const Volume& v, std::array<double, 2> dataRange) const;
};

/// The world length ParaView uses by default as the scalar opacity unit distance of a volume: the box
/// diagonal over the cube root of the number of cells.
double paraViewUnitDistance(const Volume& v);

} // namespace volcl::cli
