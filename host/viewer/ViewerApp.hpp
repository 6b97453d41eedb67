// The viewer's two front ends: an interactive GLFW window and a headless EGL run, both presenting
// ViewerSession frames through the same FramePresenter.
#pragma once

#include "host/image/ImageIo.hpp"
#include "host/viewer/ViewerSession.hpp"

#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

namespace volcl::viewer {

/// Where one presented frame's time went (milliseconds, wall clock).
struct FrameRecord {
    int index = 0;
    bool interactive = false;
    int width = 0, height = 0; ///< rendered size (the viewport may be larger)
    double step = 0.0;
    double setupMs = 0.0, renderMs = 0.0, kernelMs = 0.0;
    double presentMs = 0.0; ///< PBO upload + draw + glFinish
    double frameMs = 0.0;   ///< all of it: what the adaptive controller sees
};

struct HeadlessOptions {
    int width = 512, height = 512; ///< viewport (framebuffer) size
    int frames = 1;                ///< the first and the last are still, full-quality frames
    double orbitDegrees = 0.0;     ///< yaw before each frame between them; non-zero = interacting
    std::string keys;              ///< key actions applied before the first frame (see keyBindingsHelp())
    std::filesystem::path output;  ///< PNG/EXR of the last frame as read back from GL; empty: none
    bool quiet = false;
};

struct HeadlessResult {
    std::vector<FrameRecord> frames;
    ImageBuffer readback; ///< the last frame read back from the framebuffer (8-bit values as k/255)
    std::string gl;       ///< EGL platform, GL version and renderer
};

/// Runs `frames` frames through an EGL offscreen context: render, PBO upload, draw into a framebuffer
/// object, and read the last frame back. Writes `output` atomically when set. Progress lines go to `log`.
HeadlessResult runHeadless(ViewerSession& session, const HeadlessOptions& options, std::ostream& log);

struct WindowOptions {
    int width = 768, height = 768;
    std::filesystem::path screenshot = "volcl-view.png"; ///< `s` writes here (numbered after the first)
    bool quiet = false;
};

/// Opens a GLFW window (OpenGL 3.3 core) and runs until it is closed or `q`/Escape is pressed.
/// Throws volcl::Error when no window can be opened (no display).
void runWindow(ViewerSession& session, const WindowOptions& options, std::ostream& log);

/// Percentile (0..100) of the samples by linear interpolation between order statistics; 0 when empty.
double percentile(std::vector<double> samples, double p);

} // namespace volcl::viewer
