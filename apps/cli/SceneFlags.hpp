// Command-line flags that build or override a Scene: shared by `volcl render`, `bench render` and `view`.
#pragma once

#include "apps/cli/CliParsing.hpp"
#include "apps/cli/MeshInfo.hpp"
#include "host/io/NiftiMetadata.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <vector>

namespace volcl::cli {

/// Places `v` as the volume a .vcz holds was placed: by the NIfTI header the file carries (files written
/// before the codec kept directions have only that), else by the codec's direction and patient-axes keys.
/// Returns the NIfTI fields when the file carries them; throws IoError/DataError naming `name`.
std::optional<VczNifti> placeAsVczSource(Volume& v, const VczHeader& h, const std::string& name);

/// Comma-separated numbers; `count` 0 accepts any number of them. Throws UsageError naming `what`.
std::vector<double> parseNumbers(const std::string& text, std::size_t count, const std::string& what);
/// "x,y,z" -> Vec3; throws UsageError naming `what`.
Vec3 parseVec3(const std::string& text, const std::string& what);

/// Scene fields a command line may override; empty means "keep the scene's value".
struct SceneFlags {
    std::string scene, volume, tf, mode, preint, projection, eye, target, up, background, nanColor;
    std::string view, orbit, tfRange, tfUnitDistance = "auto";
    std::string filter, window, mipColor, lod, method, sort, skipping;
    std::optional<double> lodError, cacheMb;
    std::optional<std::size_t> refineBricks;
    std::optional<double> smoothing, viewHeight, fov, earlyTermination, shadowStep;
    std::optional<int> width, height, tableSize, tableLengths, k, lightVolumeCell;
    std::optional<std::size_t> frame; ///< --frame K of a time series input
    bool noSkipping = false, sobel = false, shadows = false, noShading = false;
    std::string step; ///< --step: world units, or voxels with a `vox` suffix (parseStepSpec)
    std::string
        cropBox; ///< --crop-box x0,y0,z0:x1,y1,z1, a `vox` suffix for voxel indices (parseCropBoxSpec)
    std::string shading, scattering, scatteringOrder, shadowMethod;
    std::string labels, labelTable, labelMode,
        labelBoundary;                    ///< --labels FILE, --label-table, --label-mode, --label-boundary
    std::string gradient;                 ///< --gradient central|sobel|cache|cache-nearest
    CLI::Option* shadingOption = nullptr; ///< --shading: given bare (default coefficients) or with a value
    std::optional<int> samples;
    std::vector<std::string> isos, lights, clips;
    RawReadFlags raw;
    std::string device; ///< OpenCL device selector for decoding a .vcz input whole (readSceneVolume)
    MeshReadFlags mesh; ///< --array, --q-var, --q for mesh inputs

    /// Registers every scene flag on `cmd` (`--orbit AZ,EL` places the camera in render, view and bench).
    void add(CLI::App* cmd);
    /// The scene file (if any) with the flags applied, validated. Throws UsageError. A scene without a
    /// transfer function renders with ParaView's default (loadTf); without a step, half a voxel (finish).
    Scene build() const;
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
    TransferFunction loadTf(const Scene& s, const RenderInput& in,
                            std::vector<std::string>* notes = nullptr) const;
    /// loadTf() with the data range given (a .vcz's from its index).
    TransferFunction loadTf(const Scene& s, const RenderInput& in, std::array<double, 2> dataRange,
                            std::vector<std::string>* notes = nullptr) const;
    /// Once the volume is read: resolves a step in voxels (the default half voxel), frames the camera the scene and flags leave incomplete (a named view,
    /// an orbit, a missing orthographic height or target, or the default view of anatomical data) and
    /// applies the lighting defaults. Returns one note per default applied (stderr and `--explain`).
    std::vector<std::string> finish(Scene& s, const Volume& v) const;
    /// `e` with the scene file's name in front, when there is a scene file and the message does not already
    /// start with it: a usage error caused by a scene file's values names that file.
    UsageError namingSceneFile(const UsageError& e) const;
    /// The scene's transfer function as the render uses it: ParaView's default when the scene has none,
    /// normalised maps spread over the data range, `--tf-range` applied, opacity per
    /// `--tf-unit-distance` (default auto). The defaults it applies are added to `notes` when given.
    TransferFunction loadTf(const Scene& s, const Volume& v, std::vector<std::string>* notes = nullptr) const;
    /// As above with the data range given (a .vcz's index range, without scanning voxels); `v` supplies the
    /// grid's geometry only.
    TransferFunction loadTf(const Scene& s, const Volume& v, std::array<double, 2> dataRange,
                            std::vector<std::string>* notes = nullptr) const;
};

/// The world length ParaView uses by default as the scalar opacity unit distance of a volume: the box
/// diagonal over the cube root of the number of cells.
double paraViewUnitDistance(const Volume& v);

} // namespace volcl::cli
