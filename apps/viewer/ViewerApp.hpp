// The viewer's two front ends: an interactive GLFW window and a headless EGL run, both presenting
// ViewerSession frames through the same FramePresenter.
#pragma once

#include "apps/viewer/GlPresenter.hpp"
#include "apps/viewer/ViewerSession.hpp"
#include "host/image/ImageIo.hpp"

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
    double uploadMs = 0.0;  ///< transport: the frame into the GL texture (PBO or shared buffer) + glFinish
    double presentMs = 0.0; ///< transport + draw (+ overlay) + glFinish
    double frameMs = 0.0;   ///< all of it: what the adaptive controller sees
};

struct HeadlessOptions {
    int width = 512, height = 512; ///< viewport (framebuffer) size
    int frames = 1;                ///< the first and the last are still, full-quality frames (after preview-
                                   ///< tier frames, still frames follow until the refinement is done)
    int stillFrames = 0;           ///< more full-quality frames after those, the view unchanged (benchmarks)
    double orbitDegrees = 0.0;     ///< yaw before each frame between them; non-zero = interacting
    std::string keys;              ///< key actions applied before the first frame (see keyBindingsHelp())
    std::filesystem::path output;  ///< PNG/EXR of the last frame as read back from GL; empty: none
    FrameTransport transport = FrameTransport::Pbo; ///< ClGlSharing needs the session's context made for it
    bool overlay =
        false; ///< draw the text overlay (off: the read-back is the volume image alone); `o` in keys flips it
    bool quiet = false;
};

struct HeadlessResult {
    std::vector<FrameRecord> frames;
    ImageBuffer readback; ///< the last frame read back from the framebuffer (8-bit values as k/255)
    std::string gl;       ///< EGL platform, GL version and renderer
};

class HeadlessGlContext;

/// Runs `frames` frames through an EGL offscreen context: render, upload (PBO or shared buffer), draw into
/// a framebuffer object, and read the last frame back. Writes `output` atomically when set. Progress lines
/// go to `log`. The first form makes its own context (PBO transport only: a shared CL context must be made
/// after the GL one, see ClGlSharing.hpp).
HeadlessResult runHeadless(ViewerSession& session, const HeadlessOptions& options, std::ostream& log);
HeadlessResult runHeadless(ViewerSession& session, const HeadlessOptions& options, HeadlessGlContext& gl,
                           std::ostream& log);

struct WindowOptions {
    int width = 768, height = 768;
    std::filesystem::path screenshot = "volcl-view.png"; ///< `s` writes here (numbered after the first)
    FrameTransport transport = FrameTransport::Pbo;
    bool overlay = true; ///< `o` toggles it
    bool quiet = false;
};

/// A GLFW window with a current OpenGL 3.3 core context. Made before the OpenCL context when frames are
/// to be shared (cl_khr_gl_sharing needs the GL context first). Throws volcl::Error when no window can be
/// opened (no display).
class ViewerWindow {
public:
    ViewerWindow(int width, int height);
    ~ViewerWindow();
    ViewerWindow(const ViewerWindow&) = delete;
    ViewerWindow& operator=(const ViewerWindow&) = delete;
    void* handle() const noexcept { return window_; }

private:
    void* window_ = nullptr;
};

/// Runs the window until it is closed or `q`/Escape is pressed. The first form opens its own window.
void runWindow(ViewerSession& session, const WindowOptions& options, std::ostream& log);
void runWindow(ViewerSession& session, const WindowOptions& options, ViewerWindow& window, std::ostream& log);

/// The overlay's lines: frame time and fps, rendered size and step (adaptive level), mode and TF, what the
/// kernel compiles in, the transport. Lists are wrapped to `maxChars`.
std::vector<std::string> overlayLines(const ViewerSession& session, const ViewerFrame& frame, double frameMs,
                                      FrameTransport transport, std::size_t maxChars);

/// Percentile (0..100) of the samples by linear interpolation between order statistics; 0 when empty.
double percentile(std::vector<double> samples, double p);

} // namespace volcl::viewer
