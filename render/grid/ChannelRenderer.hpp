// Multi-channel grid rendering: up to 4 channels on one grid, one TF each, blended additively, by maximum
// or drawn directly as colour; the OpenCL renderer (cl/render/raymarch_channels.cl) and its double reference.
#pragma once

#include "core/Channels.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/Reference.hpp"
#include "render/Scene.hpp"

#include <cstdint>
#include <string_view>
#include <vector>

namespace volcl {

/// How the channels' samples combine. Additive: per sample the channels' extinctions add and each emits
/// its TF colour in proportion to its extinction (the emission-absorption model of a mixture, as napari and
/// Imaris blend fluorescence channels). Maximum: a MIP per channel, each maximum's TF colour added with
/// opacity 1 - exp(-tau) (tau over one world unit). DirectColor: channels 0, 1, 2 are r, g, b (integers
/// scaled to [0, 1] by their type's maximum, floats as stored); channel 3 (else the luminance 0.2126 r +
/// 0.7152 g + 0.0722 b) is the opacity value that channel 0's TF turns into an extinction.
enum class ChannelBlend : std::uint8_t { Additive, Maximum, DirectColor };

/// Parses "additive", "max" (or "maximum"), "direct"; throws UsageError otherwise.
ChannelBlend parseChannelBlend(std::string_view name);
std::string_view channelBlendName(ChannelBlend blend) noexcept;

/// One channel's classification.
struct ChannelLayer {
    TransferFunction tf;
    bool visible = true;
};

/// The classification of every channel: one layer per channel (DirectColor: layer 0's TF maps the opacity
/// value in [0, 1] to extinction; others are ignored).
struct ChannelStyle {
    ChannelBlend blend = ChannelBlend::Additive;
    std::vector<ChannelLayer> layers;
};

inline constexpr std::size_t kMaxRenderChannels = 4;

/// The channels a multi-channel scene draws: each entry of scene.channels from its file and component
/// (read with `options`; entries naming the scene's volume share one read), or, with none given, every
/// channel of scene.volume. Throws what the readers throw, and DataError when the channels' grids differ.
ChannelVolume readSceneChannels(const Scene& scene, const ReadOptions& options);
/// The style of a multi-channel scene: per channel its TF (TransferFunction::forRender over the channel's
/// finite value range, opacity unit distance `opacityUnitDistance`) and visibility; direct colour takes
/// scene.tf (default: ParaView's ramp over [0, 1]) as the opacity TF.
ChannelStyle sceneChannelStyle(const Scene& scene, const ChannelVolume& volume, double opacityUnitDistance);

/// Throws UsageError for what the multi-channel renderer does not draw (more than 4 channels, a layer count
/// that does not match, direct colour without 3 or 4 channels, modes other than dvr (mip for Maximum),
/// shading, shadows, scattering, fog, iso-surfaces, cubic filters, smoothing, pre-integration), each with
/// one line; clip planes and the crop box are kept.
void checkChannelScene(const ChannelVolume& volume, const ChannelStyle& style, const Scene& scene);

/// Renders a multi-channel grid with OpenCL. The volume must outlive the renderer. Example:
/// ```
/// volcl::ChannelRenderer r(cc, channels, style, scene);
/// volcl::ImageBuffer img = r.render(); // R, G, B, A: linear, associated
/// ```
class ChannelRenderer {
public:
    /// Uploads every channel in its own type. Throws UsageError (checkChannelScene).
    ChannelRenderer(ComputeContext& cc, const ChannelVolume& volume, ChannelStyle style, const Scene& scene);
    ImageBuffer render();
    /// Kernel milliseconds of the last render().
    double lastMilliseconds() const noexcept { return lastMs_; }

private:
    ComputeContext& cc_;
    const ChannelVolume& volume_;
    ChannelStyle style_;
    Scene scene_;
    std::vector<cl::Buffer> voxels_;
    DeviceBuffer<VolclTfKnot> knots_;
    cl::Kernel kernel_;
    double lastMs_ = 0.0;
};

/// The same ray integral in double precision with the exact TFs (midpoint rule at options.step, trilinear
/// samples, no early termination), channels as ChannelRenderer::render().
ImageBuffer referenceChannelRender(const ChannelVolume& volume, const ChannelStyle& style, const Scene& scene,
                                   const ReferenceOptions& options = {});

} // namespace volcl
