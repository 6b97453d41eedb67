// The one place a scene's data file becomes a renderer: opens the input and picks the renderer that draws it.
#pragma once

#include "host/io/VolumeIo.hpp"
#include "host/mesh/MeshIo.hpp"
#include "render/Reference.hpp"
#include "render/VolumeRenderer.hpp"

#include <filesystem>
#include <memory>
#include <string>

namespace volcl {

class Volume;
class VczReader;

/// A grid as the renderers' kernels sample it: a float64 volume as float32 (finite values beyond float's range
/// clamped), any other unchanged. The one place rendering narrows float64 (RenderInput and the channel
/// renderer take their grids through it); readers, writers and the codec keep float64.
Volume kernelVoxels(Volume v);

/// The data a scene renders, opened once: a grid (a Volume from any reader), a frame of a compressed-brick
/// .vcz file, or a tetrahedral mesh (any mesh reader; render.method picks its renderer), each with its own
/// renderer, so the CLI and viewer need no change. A renderer made from an input borrows its data: keep the
/// input alive.
/// Example:
/// ```
/// volcl::RenderInput in = volcl::RenderInput::open(scene.volume);
/// std::unique_ptr<volcl::VolumeRenderer> r = in.makeRenderer(cc, tf, scene);
/// ```
class RenderInput {
public:
    /// Grid: a Volume in memory. Bricks: one frame of a .vcz, rendered from its compressed bricks. Mesh: a
    /// tetrahedral mesh.
    enum class Kind { Grid, Bricks, Mesh };

    /// Reads `path` with the matching reader: a .vcz as Bricks (frame 0), a mesh (a .vcm or any format
    /// mesh::detectMeshFormat() recognises; read with `meshOptions`), else a volume. Throws what the
    /// readers throw (IoError, DataError).
    static RenderInput open(const std::filesystem::path& path, const ReadOptions& options = {},
                            const mesh::MeshReadOptions& meshOptions = {});
    /// Frame `frame` of a .vcz file (header and index validated; nothing decoded). Throws IoError.
    static RenderInput openVcz(const std::filesystem::path& path, std::size_t frame = 0);
    /// The mesh file `path` read with `meshOptions`, refused (DataError naming the file) when more of its tets
    /// fold over a neighbour than kMaxFoldedFaceShare of them (at least kFoldedFacesAlways folded faces are
    /// always accepted): such a file is no tetrahedral mesh (a grid with shuffled points made the cell caster
    /// search for minutes), and `volcl info` still describes it.
    static RenderInput openMesh(const std::filesystem::path& path,
                                const mesh::MeshReadOptions& meshOptions = {});
    static constexpr double kMaxFoldedFaceShare = 0.1;
    static constexpr std::size_t kFoldedFacesAlways = 1000;
    /// An input owning `mesh`.
    static RenderInput fromMesh(mesh::TetMesh mesh);
    /// An input borrowing `mesh`, which must outlive it and every renderer made from it.
    static RenderInput borrowMesh(const mesh::TetMesh& mesh);
    /// An input owning `volume`.
    static RenderInput fromVolume(Volume volume);
    /// An input borrowing `volume`, which must outlive it and every renderer made from it.
    static RenderInput borrow(const Volume& volume);

    Kind kind() const noexcept { return vcz_ ? Kind::Bricks : mesh_ ? Kind::Mesh : Kind::Grid; }
    /// The compressed file of a Bricks input (nullptr for other kinds) and its frame.
    const VczReader* bricks() const noexcept { return vcz_.get(); }
    std::size_t frame() const noexcept { return frame_; }
    /// The grid, for the peers and tools that need one (VTK's ray caster); nullptr for other kinds.
    const Volume* grid() const noexcept { return volume_.get(); }
    /// The mesh; nullptr for other kinds.
    const mesh::TetMesh* mesh() const noexcept { return mesh_.get(); }
    WorldBox bounds() const;
    /// The length the default step counts in: a grid's finest spacing, a mesh's approximate cell length.
    double cellLength() const;
    /// ParaView's automatic scalar opacity unit distance (the bounds domain's approximate cell length):
    /// the box diagonal over the cube root of the cell count (grid cells or tetrahedra); 1 for an empty box.
    double approximateCellLength() const;
    /// `scene` with a step in voxels (Scene::stepVoxels) turned into world units for this input; the renderer,
    /// reference and plan made here all use it, so a scene file's `"0.5vox"` means the same everywhere.
    Scene resolved(const Scene& scene) const;
    /// Turns a crop box in voxels (CropBox::voxels) into world units of this grid or .vcz (index i at origin +
    /// spacing i); returns the note (empty when there was nothing to turn). Throws UsageError for a mesh.
    std::string resolveCropBox(Scene& scene) const;
    /// Smallest and largest finite data value.
    ValueRange valueRange() const;
    /// One line for progress messages: "180x216x180 uint8", "51040 tets, 17344 points".
    std::string summary() const;

    /// What `scene` would compile on this data, without a device (`volcl render --explain`).
    EffectPlan planEffects(const Scene& scene, const TransferFunction& tf) const;
    /// The scene through the double-precision reference of this input's kind (no device needed).
    ImageBuffer renderReference(const TransferFunction& tf, const Scene& scene,
                                const ReferenceOptions& options = {}) const;
    /// The renderer for this input's kind.
    std::unique_ptr<VolumeRenderer> makeRenderer(ComputeContext& cc, const TransferFunction& tf,
                                                 const Scene& scene) const;

private:
    explicit RenderInput(std::shared_ptr<const Volume> volume);
    explicit RenderInput(std::shared_ptr<const mesh::TetMesh> mesh);
    std::shared_ptr<const Volume> volume_;
    std::shared_ptr<const VczReader> vcz_;
    std::size_t frame_ = 0;
    std::shared_ptr<const mesh::TetMesh> mesh_;
};

} // namespace volcl
