// Window (GLFW) and headless (EGL) front ends of the viewer: input, frame loop, presentation, screenshots.
#include "apps/viewer/ViewerApp.hpp"

#include "apps/viewer/ClGlSharing.hpp"
#include "apps/viewer/GlPresenter.hpp"
#include "apps/viewer/HeadlessGl.hpp"
#include "apps/viewer/Overlay.hpp"
#include "core/Error.hpp"
#include "core/runtime/Timing.hpp"

#include <epoxy/gl.h>
// GLFW after epoxy: epoxy provides the GL declarations, GLFW must not pull in its own.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <memory>
#include <numbers>

namespace volcl::viewer {
namespace {

// What presents frames: the presenter, the shared buffer on the cl_khr_gl_sharing path, the overlay.
struct FrameSink {
    FramePresenter presenter;
    std::unique_ptr<SharedFrameBuffer> shared; ///< set only for FrameTransport::ClGlSharing
    std::unique_ptr<TextOverlay> overlay;      ///< set when the overlay may be drawn
    FrameTransport transport = FrameTransport::Pbo;

    FrameSink(ViewerSession& session, FrameTransport t, bool withOverlay) : transport(t) {
        if (t == FrameTransport::ClGlSharing) shared = std::make_unique<SharedFrameBuffer>(session.compute());
        if (withOverlay) overlay = std::make_unique<TextOverlay>();
    }
};

struct PresentTimes {
    double uploadMs = 0.0, totalMs = 0.0;
};

// Draws the uploaded frame and, when on, the overlay into the bound framebuffer.
void drawFrame(FrameSink& sink, const ViewerSession& session, const ViewerFrame& frame, int width, int height,
               bool overlay, double shownFrameMs) {
    sink.presenter.draw(width, height, session.currentScene().background);
    if (overlay && sink.overlay) {
        sink.overlay->setText(overlayLines(session, frame, shownFrameMs, sink.transport,
                                           std::size_t(std::max(width - 2 * kTextMargin, 0) / kGlyphWidth)));
        sink.overlay->draw(width, height);
    }
}

// Presents one frame into the bound framebuffer and waits for GL, so the frame time covers the whole path.
// The overlay shows the previous frame's total time (this one's is not known until it is drawn).
PresentTimes present(FrameSink& sink, ViewerSession& session, const ViewerFrame& frame, int width, int height,
                     bool overlay, double shownFrameMs) {
    Stopwatch sw;
    PresentTimes t;
    if (sink.shared)
        sink.shared->present(session.renderer().outputBuffer(), frame.image.width, frame.image.height,
                             sink.presenter);
    else
        sink.presenter.upload(frame.image);
    glFinish();
    t.uploadMs = sw.milliseconds();
    drawFrame(sink, session, frame, width, height, overlay, shownFrameMs);
    glFinish();
    t.totalMs = sw.milliseconds();
    return t;
}

FrameRecord record(int index, const ViewerFrame& f, double step, PresentTimes present, double frameMs) {
    FrameRecord r;
    r.index = index;
    r.interactive = f.interactive;
    r.width = f.image.width;
    r.height = f.image.height;
    r.step = step;
    r.setupMs = f.setupMs;
    r.renderMs = f.renderMs;
    r.kernelMs = f.kernelMs;
    r.uploadMs = present.uploadMs;
    r.presentMs = present.totalMs;
    r.frameMs = frameMs;
    return r;
}

} // namespace

double percentile(std::vector<double> samples, double p) {
    if (samples.empty()) return 0.0;
    std::sort(samples.begin(), samples.end());
    const double pos = std::clamp(p, 0.0, 100.0) / 100.0 * double(samples.size() - 1);
    const std::size_t i = std::size_t(std::floor(pos));
    const std::size_t j = std::min(i + 1, samples.size() - 1);
    return samples[i] + (samples[j] - samples[i]) * (pos - double(i));
}

std::vector<std::string> overlayLines(const ViewerSession& session, const ViewerFrame& frame, double frameMs,
                                      FrameTransport transport, std::size_t maxChars) {
    char buf[160];
    std::vector<std::string> lines;
    std::snprintf(buf, sizeof buf, "last frame %.0f ms  %.1f fps", frameMs,
                  frameMs > 0 ? 1000.0 / frameMs : 0.0);
    lines.emplace_back(buf);
    const Scene scene = session.currentScene();
    const std::string level = frame.level.tier != GridMethod::Raymarch
                                  ? " (" + std::string(gridMethodName(frame.level.tier)) + ")"
                              : frame.level.full() ? std::string()
                                                   : std::string(" (interactive)");
    std::snprintf(buf, sizeof buf, "render %dx%d step %.3g%s", frame.image.width, frame.image.height,
                  scene.step * frame.level.stepScale, level.c_str());
    lines.emplace_back(buf);
    if (session.adaptive().options().enabled)
        std::snprintf(buf, sizeof buf, "adaptive: target %.0f ms", session.adaptive().options().targetMs);
    else
        std::snprintf(buf, sizeof buf, "adaptive: off");
    lines.emplace_back(buf);
    lines.push_back("mode " + std::string(renderModeName(scene.mode)) + "  TF " + session.tfPresetName());
    for (auto& l : wrapList("compiled: ", session.compiledSummary(), std::max<std::size_t>(maxChars, 24)))
        lines.push_back(std::move(l));
    lines.push_back("transport: " + std::string(frameTransportName(transport)));
    return lines;
}

HeadlessResult runHeadless(ViewerSession& session, const HeadlessOptions& o, std::ostream& log) {
    if (o.transport != FrameTransport::Pbo)
        throw Error("view: the shared transport needs the OpenCL context made after the GL one");
    HeadlessGlContext gl;
    return runHeadless(session, o, gl, log);
}

HeadlessResult runHeadless(ViewerSession& session, const HeadlessOptions& o, HeadlessGlContext& gl,
                           std::ostream& log) {
    if (o.width <= 0 || o.height <= 0) throw UsageError("view: --width and --height must be positive");
    if (o.frames < 1) throw UsageError("view: --frames must be at least 1");
    if (!std::isfinite(o.orbitDegrees)) throw UsageError("view: --spin must be a finite angle");
    bool overlay = o.overlay;
    for (char k : o.keys) {
        const auto action = actionForKey(k);
        if (!action) throw UsageError(std::string("view: --keys: no action is bound to '") + k + "'");
        if (*action == ViewerAction::Screenshot || *action == ViewerAction::Quit) continue;
        if (*action == ViewerAction::ToggleOverlay) {
            overlay = !overlay;
            continue;
        }
        const std::string what = session.apply(*action);
        if (!o.quiet && !what.empty()) log << "view: " << what << '\n';
    }

    HeadlessResult result;
    result.gl = gl.description();
    if (!o.quiet) log << "view: " << result.gl << '\n';
    FrameSink sink(session, o.transport, overlay);
    OffscreenFramebuffer target(o.width, o.height);
    double lastFrameMs = 0.0;
    if (o.stillFrames < 0) throw UsageError("view: still frames must not be negative");
    const auto frame = [&](int i, bool interactive) {
        Stopwatch sw;
        ViewerFrame f = session.renderFrame(o.width, o.height, interactive);
        target.bind();
        const PresentTimes pt = present(sink, session, f, o.width, o.height, overlay, lastFrameMs);
        const double frameMs = sw.milliseconds();
        lastFrameMs = frameMs;
        session.frameDone(f, frameMs);
        result.frames.push_back(record(i, f, session.currentScene().step * f.level.stepScale, pt, frameMs));
    };
    int i = 0;
    for (; i < o.frames + o.stillFrames; ++i) {
        // Like a user: the viewer opens on a full-quality frame, the orbit follows, the view settles.
        const bool interactive = i > 0 && i + 1 < o.frames && o.orbitDegrees != 0.0;
        if (interactive) session.camera().orbit(o.orbitDegrees * std::numbers::pi / 180.0, 0.0);
        frame(i, interactive);
    }
    // After preview-tier frames the settled view refines to the ray marcher's frame over a few more frames.
    for (; session.refining(); ++i)
        frame(i, false);
    result.readback = readFramebuffer(o.width, o.height);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    if (!o.output.empty()) writeImage(result.readback, o.output);
    return result;
}

namespace {

struct InputState {
    ViewerSession* session = nullptr;
    double lastX = 0.0, lastY = 0.0;
    int button = -1; ///< GLFW mouse button held, -1 for none
    bool shift = false;
    double orbitX = 0.0, orbitY = 0.0, panX = 0.0, panY = 0.0,
           zoomSteps = 0.0; ///< pending since the last frame
    std::deque<char> keys;
    bool quit = false;
};

InputState& inputOf(GLFWwindow* w) {
    return *static_cast<InputState*>(glfwGetWindowUserPointer(w));
}

void onKey(GLFWwindow* w, int key, int, int action, int mods) {
    InputState& in = inputOf(w);
    in.shift = (mods & GLFW_MOD_SHIFT) != 0;
    if (action != GLFW_PRESS) return;
    if (key == GLFW_KEY_ESCAPE) {
        in.quit = true;
        return;
    }
    if (key >= GLFW_KEY_A && key <= GLFW_KEY_Z)
        in.keys.push_back(char('a' + (key - GLFW_KEY_A)));
    else if (key >= GLFW_KEY_0 && key <= GLFW_KEY_9)
        in.keys.push_back(char('0' + (key - GLFW_KEY_0)));
}

void onButton(GLFWwindow* w, int button, int action, int mods) {
    InputState& in = inputOf(w);
    in.shift = (mods & GLFW_MOD_SHIFT) != 0;
    if (action == GLFW_PRESS) {
        in.button = button;
        glfwGetCursorPos(w, &in.lastX, &in.lastY);
    } else if (button == in.button) {
        in.button = -1;
    }
}

void onCursor(GLFWwindow* w, double x, double y) {
    InputState& in = inputOf(w);
    const double dx = x - in.lastX, dy = y - in.lastY;
    in.lastX = x;
    in.lastY = y;
    if (in.button < 0) return;
    int ww = 1, wh = 1;
    glfwGetWindowSize(w, &ww, &wh);
    const double h = std::max(wh, 1);
    if (in.button == GLFW_MOUSE_BUTTON_LEFT && !in.shift) {
        in.orbitX += dx / h * std::numbers::pi; // a drag across the window height turns half a revolution
        in.orbitY += dy / h * std::numbers::pi;
    } else {
        in.panX += dx / h;
        in.panY -= dy / h;
    }
}

void onScroll(GLFWwindow* w, double, double yoffset) {
    inputOf(w).zoomSteps += yoffset;
}

std::filesystem::path numbered(const std::filesystem::path& p, int n) {
    if (n == 0) return p;
    return p.parent_path() / (p.stem().string() + "-" + std::to_string(n) + p.extension().string());
}

} // namespace

ViewerWindow::ViewerWindow(int width, int height) {
    if (width <= 0 || height <= 0) throw UsageError("view: --width and --height must be positive");
    if (!glfwInit()) {
        const char* why = nullptr;
        glfwGetError(&why);
        throw Error(std::string("view: cannot open a window (") + (why ? why : "GLFW initialisation failed") +
                    "); set DISPLAY, or use --headless");
    }
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    GLFWwindow* w = glfwCreateWindow(width, height, "volcl view", nullptr, nullptr);
    if (!w) {
        const char* why = nullptr;
        glfwGetError(&why);
        glfwTerminate();
        throw Error(std::string("view: cannot create an OpenGL 3.3 core window (") +
                    (why ? why : "unknown reason") + ")");
    }
    glfwMakeContextCurrent(w);
    glfwSwapInterval(0); // frame pacing is the adaptive controller's job, not the vertical retrace's
    window_ = w;
}

ViewerWindow::~ViewerWindow() {
    glfwDestroyWindow(static_cast<GLFWwindow*>(window_));
    glfwTerminate();
}

void runWindow(ViewerSession& session, const WindowOptions& o, std::ostream& log) {
    if (o.transport != FrameTransport::Pbo)
        throw Error("view: the shared transport needs the OpenCL context made after the GL one");
    ViewerWindow window(o.width, o.height);
    runWindow(session, o, window, log);
}

void runWindow(ViewerSession& session, const WindowOptions& o, ViewerWindow& window, std::ostream& log) {
    GLFWwindow* w = static_cast<GLFWwindow*>(window.handle());
    InputState in;
    in.session = &session;
    glfwSetWindowUserPointer(w, &in);
    glfwSetKeyCallback(w, onKey);
    glfwSetMouseButtonCallback(w, onButton);
    glfwSetCursorPosCallback(w, onCursor);
    glfwSetScrollCallback(w, onScroll);

    FrameSink sink(session, o.transport, true);
    bool overlay = o.overlay;
    double lastFrameMs = 0.0;
    if (!o.quiet)
        log << "view: OpenGL " << reinterpret_cast<const char*>(glGetString(GL_VERSION)) << ", "
            << reinterpret_cast<const char*>(glGetString(GL_RENDERER)) << "\n"
            << keyBindingsHelp();

    bool needFull = true, saveShot = false;
    bool redraw = false; // draw the frame on screen again (overlay toggled, screenshot of a still frame)
    ViewerFrame shown;   // what is on screen, without its pixels (they are in the texture)
    int shots = 0, lastW = 0, lastH = 0;
    using Clock = std::chrono::steady_clock;
    Clock::time_point lastMotion = Clock::now();
    // Input quiet this long ends an interaction: the next frame is the full-quality one.
    constexpr auto kSettle = std::chrono::milliseconds(150);
    bool interacting = false;

    while (!glfwWindowShouldClose(w) && !in.quit) {
        if (needFull || redraw)
            glfwPollEvents();
        else
            glfwWaitEventsTimeout(interacting ? 0.02 : 0.25); // idle: sleep until input arrives

        while (!in.keys.empty()) {
            const char k = in.keys.front();
            in.keys.pop_front();
            const auto action = actionForKey(k);
            if (!action) continue;
            if (*action == ViewerAction::Quit)
                in.quit = true;
            else if (*action == ViewerAction::Screenshot) {
                // A still, full-quality frame on screen is saved as it is; else after the next full one.
                saveShot = true;
                if (shown.image.width > 0 && shown.level.full() && !interacting)
                    redraw = true;
                else
                    needFull = true;
            } else if (*action == ViewerAction::ToggleOverlay) {
                overlay = !overlay;
                if (!o.quiet) log << "view: overlay " << (overlay ? "on" : "off") << '\n';
                redraw = shown.image.width > 0; // no new render: the frame is in the texture
            } else {
                const std::string what = session.apply(*action);
                if (!o.quiet && !what.empty()) log << "view: " << what << '\n';
                needFull = true;
            }
        }
        if (in.quit) break;

        const bool moved =
            in.orbitX != 0.0 || in.orbitY != 0.0 || in.panX != 0.0 || in.panY != 0.0 || in.zoomSteps != 0.0;
        if (moved) {
            session.camera().orbit(in.orbitX, in.orbitY);
            session.camera().pan(in.panX, in.panY);
            if (in.zoomSteps != 0.0) session.camera().zoom(std::pow(0.9, in.zoomSteps));
            in.orbitX = in.orbitY = in.panX = in.panY = in.zoomSteps = 0.0;
            lastMotion = Clock::now();
            interacting = true;
        } else if (interacting && Clock::now() - lastMotion > kSettle) {
            // The mouse rests (button held or not): full quality until it moves again.
            interacting = false;
            needFull = true;
        }

        int fw = 0, fh = 0;
        glfwGetFramebufferSize(w, &fw, &fh);
        if (fw <= 0 || fh <= 0) continue; // minimised
        if (fw != lastW || fh != lastH) {
            lastW = fw;
            lastH = fh;
            needFull = true;
        }
        if (!moved && !needFull && !redraw) continue;
        if (!moved && !needFull) {
            glBindFramebuffer(GL_FRAMEBUFFER, 0);
            drawFrame(sink, session, shown, fw, fh, overlay, lastFrameMs);
            if (saveShot) {
                const std::filesystem::path path = numbered(o.screenshot, shots++);
                glReadBuffer(GL_BACK);
                writeImage(readFramebuffer(fw, fh), path);
                if (!o.quiet) log << "view: screenshot " << path.string() << '\n';
                saveShot = false;
            }
            glfwSwapBuffers(w);
            redraw = false;
            continue;
        }
        redraw = false;

        const bool interactiveFrame = moved;
        Stopwatch sw;
        ViewerFrame f;
        try {
            f = session.renderFrame(fw, fh, interactiveFrame);
        } catch (const UsageError& e) {
            // A toggle the renderer refuses (e.g. a step limit) must not close the window.
            log << "view: " << e.what() << '\n';
            needFull = false;
            continue;
        }
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        present(sink, session, f, fw, fh, overlay, lastFrameMs);
        const double frameMs = sw.milliseconds();
        lastFrameMs = frameMs;
        session.frameDone(f, frameMs);
        if (saveShot && !interactiveFrame) {
            const std::filesystem::path path = numbered(o.screenshot, shots++);
            glReadBuffer(GL_BACK);
            writeImage(readFramebuffer(fw, fh), path);
            if (!o.quiet) log << "view: screenshot " << path.string() << '\n';
            saveShot = false;
        }
        glfwSwapBuffers(w);
        glfwSetWindowTitle(w, session.title(f, frameMs).c_str());
        shown = f;
        shown.image.pixels = {};
        // A still frame after preview-tier frames starts a refinement: the next frames finish it.
        if (!interactiveFrame) needFull = session.refining();
    }
}

} // namespace volcl::viewer
