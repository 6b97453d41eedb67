// What `volcl view` and `volcl bench view` share: the viewer's flags, the setup of OpenCL, OpenGL and the
// session in the order context sharing needs, headless options and the per-frame CSV.
#pragma once

#include "apps/cli/Commands.hpp"
#include "apps/cli/SceneFlags.hpp"
#include "apps/viewer/GlPresenter.hpp"
#include "apps/viewer/HeadlessGl.hpp"
#include "apps/viewer/ViewerApp.hpp"
#include "apps/viewer/ViewerSession.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"

#include <CLI/CLI.hpp>

#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace volcl::cli {

/// The flags of `volcl view`; `volcl bench view` sets its own defaults on them.
struct ViewArgs {
    std::string input, output, stats, keys, transport = "auto";
    SceneFlags scene;
    int frames = 1;
    double spin = 0.0, targetMs = 100.0; ///< spin: --spin, degrees of yaw per in-between frame
    bool headless = false, noAdaptive = false, overlay = false, noOverlay = false;
    bool noPreviewTiers = false; ///< --no-preview-tiers: moving views use the coarse ray marcher
};

/// Everything a viewer run needs, made in the order cl_khr_gl_sharing requires: the OpenCL device is
/// probed for the extension first, then the GL context is made, then (for sharing) the OpenCL context that
/// shares with it, then the session that renders on it.
struct ViewerSetup {
    Scene scene;
    std::optional<RenderInput> input;
    std::optional<TransferFunction> tf;
    viewer::FrameTransport transport = viewer::FrameTransport::Pbo;
    std::unique_ptr<viewer::HeadlessGlContext> headlessGl;
    std::unique_ptr<viewer::ViewerWindow> window;
    std::unique_ptr<ComputeContext> cc;
    std::unique_ptr<viewer::ViewerSession> session;

    ViewerSetup(const ViewArgs& a, const GlobalOptions& global, bool headless);
};

/// Headless options from the flags and the setup (size, frames, orbit, keys, output, transport, overlay).
viewer::HeadlessOptions headlessOptions(const ViewArgs& a, const ViewerSetup& s, bool quiet);

/// One CSV row per frame: index, interactive, size, step and the stage milliseconds.
std::string statsCsv(const std::vector<viewer::FrameRecord>& frames);

/// The flags `view` and `bench view` share: the scene flags, --target-ms, --no-adaptive, --transport, --keys.
void addViewFlags(CLI::App* cmd, ViewArgs& a);

} // namespace volcl::cli
