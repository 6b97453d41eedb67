// The one place a scene's data file becomes a renderer: opens the input and picks the renderer that draws it.
#pragma once

#include "host/io/VolumeIo.hpp"
#include "host/render/Reference.hpp"
#include "host/render/VolumeRenderer.hpp"

#include <filesystem>
#include <memory>
#include <string>

namespace volcl {

class Volume;
class VczReader;

/// The data a scene renders, opened once: a grid (a Volume from any reader) or a frame of a compressed-brick
/// .vcz file; a tetrahedral mesh becomes another kind here, with its own renderer, and the
/// CLI and viewer need no change. A renderer made from an input borrows its data: keep the input alive.
/// Example:
/// ```
/// volcl::RenderInput in = volcl::RenderInput::open(scene.volume);
/// std::unique_ptr<volcl::VolumeRenderer> r = in.makeRenderer(cc, tf, scene);
/// ```
class RenderInput {
public:
    /// Grid: a Volume in memory. Bricks: one frame of a .vcz, rendered from its compressed bricks.
    enum class Kind { Grid, Bricks };

    /// Reads `path` with the matching reader. Throws what the readers throw (IoError, DataError).
    static RenderInput open(const std::filesystem::path& path, const ReadOptions& options = {});
    /// Frame `frame` of a .vcz file (header and index validated; nothing decoded). Throws IoError.
    static RenderInput openVcz(const std::filesystem::path& path, std::size_t frame = 0);
    /// An input owning `volume`.
    static RenderInput fromVolume(Volume volume);
    /// An input borrowing `volume`, which must outlive it and every renderer made from it.
    static RenderInput borrow(const Volume& volume);

    Kind kind() const noexcept { return vcz_ ? Kind::Bricks : Kind::Grid; }
    /// The compressed file of a Bricks input (nullptr for other kinds) and its frame.
    const VczReader* bricks() const noexcept { return vcz_.get(); }
    std::size_t frame() const noexcept { return frame_; }
    /// The grid, for the peers and tools that need one (VTK's ray caster); nullptr for other kinds.
    const Volume* grid() const noexcept { return volume_.get(); }
    WorldBox bounds() const;
    /// Smallest and largest finite data value.
    ValueRange valueRange() const;
    /// One line for progress messages: "180x216x180 uint8".
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
    std::shared_ptr<const Volume> volume_;
    std::shared_ptr<const VczReader> vcz_;
    std::size_t frame_ = 0;
};

} // namespace volcl
