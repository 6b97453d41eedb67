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

/// The data a scene renders, opened once. Today every input is a grid (a Volume from any reader); a
/// tetrahedral mesh or a compressed-brick file becomes another kind here, with its own renderer, and the
/// CLI and viewer need no change. A renderer made from an input borrows its data: keep the input alive.
/// Example:
/// ```
/// volcl::RenderInput in = volcl::RenderInput::open(scene.volume);
/// std::unique_ptr<volcl::VolumeRenderer> r = in.makeRenderer(cc, tf, scene);
/// ```
class RenderInput {
public:
    enum class Kind { Grid };

    /// Reads `path` with the matching reader. Throws what the readers throw (IoError, DataError).
    static RenderInput open(const std::filesystem::path& path, const ReadOptions& options = {});
    /// An input owning `volume`.
    static RenderInput fromVolume(Volume volume);
    /// An input borrowing `volume`, which must outlive it and every renderer made from it.
    static RenderInput borrow(const Volume& volume);

    Kind kind() const noexcept { return Kind::Grid; }
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
};

} // namespace volcl
