// `volcl view`: the interactive OpenGL viewer and its headless EGL run (frames from the ray marcher).
#include "host/Error.hpp"
#include "host/cli/CliParsing.hpp"
#include "host/cli/Commands.hpp"
#include "host/io/AtomicFile.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/render/Scene.hpp"
#include "host/runtime/ClRuntime.hpp"
#include "host/tf/TransferFunction.hpp"
#include "host/viewer/GlPresenter.hpp"
#include "host/viewer/ViewerApp.hpp"

#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

namespace volcl::cli {
namespace {

struct ViewArgs {
    std::string input, tf, mode, output, stats, keys;
    RawReadFlags raw;
    int width = 0, height = 0, frames = 1;
    double step = 0.0, orbit = 0.0, targetMs = 100.0;
    bool headless = false, noAdaptive = false;
};

bool isSceneFile(const std::filesystem::path& p) {
    std::string ext = p.extension().string();
    for (char& c : ext)
        c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext == ".json";
}

std::string statsCsv(const std::vector<viewer::FrameRecord>& frames) {
    std::ostringstream os;
    os << "frame,interactive,width,height,step,setup_ms,render_ms,kernel_ms,present_ms,frame_ms\n";
    for (const auto& f : frames)
        os << f.index << ',' << (f.interactive ? 1 : 0) << ',' << f.width << ',' << f.height << ',' << f.step
           << ',' << f.setupMs << ',' << f.renderMs << ',' << f.kernelMs << ',' << f.presentMs << ','
           << f.frameMs << '\n';
    return os.str();
}

void runView(const ViewArgs& a, const GlobalOptions& global) {
    const std::filesystem::path input(a.input);
    Scene scene;
    if (isSceneFile(input)) {
        scene = Scene::fromFile(input);
    } else {
        scene.volume = input;
    }
    if (!a.tf.empty()) scene.tf = a.tf;
    if (!a.mode.empty()) scene.mode = parseRenderMode(a.mode);
    if (a.step != 0.0) scene.step = a.step;
    if (a.width > 0) scene.width = a.width;
    if (a.height > 0) scene.height = a.height;
    scene.validate();
    if (scene.volume.empty()) throw UsageError(a.input + ": the scene names no volume");

    const Volume volume = readVolume(scene.volume, a.raw.toReadOptions());
    std::optional<TransferFunction> tf;
    if (!scene.tf.empty()) tf = TransferFunction::fromFile(scene.tf);
    if (!a.output.empty() && a.headless) checkNotSameFile(scene.volume, a.output);

    ComputeContext cc(global.device);
    viewer::AdaptiveQualityOptions adaptive;
    adaptive.enabled = !a.noAdaptive;
    adaptive.targetMs = a.targetMs;
    viewer::ViewerSession session(cc, volume, scene, tf, scene.tf, adaptive);
    if (!global.quiet)
        std::cerr << "view: device " << cc.device().name << ", frames reach OpenGL through a "
                  << viewer::frameTransportName(viewer::FrameTransport::Pbo)
                  << (viewer::availableTransport(cc.device()) == viewer::FrameTransport::Pbo
                          ? " (the device has no cl_khr_gl_sharing)"
                          : " (the device lists cl_khr_gl_sharing; the viewer does not use it yet)")
                  << "\n";

    if (!a.headless) {
        viewer::WindowOptions w;
        w.width = scene.width;
        w.height = scene.height;
        if (!a.output.empty()) w.screenshot = a.output;
        w.quiet = global.quiet;
        viewer::runWindow(session, w, std::cerr);
        return;
    }

    viewer::HeadlessOptions h;
    h.width = scene.width;
    h.height = scene.height;
    h.frames = a.frames;
    h.orbitDegrees = a.orbit;
    h.keys = a.keys;
    h.output = a.output;
    h.quiet = global.quiet;
    const viewer::HeadlessResult r = viewer::runHeadless(session, h, std::cerr);
    if (!a.stats.empty()) {
        AtomicFile out(a.stats);
        out.write(statsCsv(r.frames));
        out.commit();
    }
    if (!global.quiet) {
        std::vector<double> interactive;
        for (const auto& f : r.frames)
            if (f.interactive) interactive.push_back(f.frameMs);
        const viewer::FrameRecord& last = r.frames.back();
        char line[256];
        if (!interactive.empty()) {
            std::snprintf(line, sizeof line,
                          "view: %zu interactive frames: median %.1f ms, p90 %.1f ms (target %.0f ms%s)\n",
                          interactive.size(), viewer::percentile(interactive, 50),
                          viewer::percentile(interactive, 90), a.targetMs,
                          a.noAdaptive ? ", adaptive quality off" : "");
            std::cerr << line;
        }
        std::snprintf(line, sizeof line,
                      "view: full-quality frame %dx%d step %g: %.1f ms (render %.1f, kernel %.1f, "
                      "present %.1f)\n",
                      last.width, last.height, last.step, last.frameMs, last.renderMs, last.kernelMs,
                      last.presentMs);
        std::cerr << line;
        std::cerr << "view: compiled: " << session.compiledSummary() << '\n';
    }
}

} // namespace

void addViewCommand(CLI::App& app, GlobalOptions& global) {
    auto* cmd = app.add_subcommand(
        "view", "Interactive OpenGL viewer of the ray marcher (or --headless through EGL)");
    auto a = std::make_shared<ViewArgs>();
    cmd->add_option("input", a->input, "Scene JSON, or a volume file (then give --tf)")->required();
    cmd->add_option("--tf", a->tf,
                    "Transfer function (canonical or ParaView JSON, RGBA strip); overrides the scene's");
    cmd->add_option("--mode", a->mode, "Start in this mode: dvr, mip, iso, xray");
    cmd->add_option("--step", a->step, "Full-quality ray step in world units (default: the scene's)");
    cmd->add_option("--width", a->width, "Window / framebuffer width (default: the scene's image width)")
        ->check(CLI::Range(1, 16384));
    cmd->add_option("--height", a->height, "Window / framebuffer height (default: the scene's image height)")
        ->check(CLI::Range(1, 16384));
    cmd->add_flag("--headless", a->headless, "No window: render through an EGL offscreen context");
    cmd->add_option("--frames", a->frames, "Headless: frames to render; the first and last are full quality")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    cmd->add_option("--orbit", a->orbit,
                    "Headless: degrees to orbit before each frame in between (interaction)");
    cmd->add_option("--keys", a->keys,
                    "Headless: key actions to apply first, e.g. \"1m\" (see the list below)");
    cmd->add_option(
        "-o,--output", a->output,
        "Headless: PNG/EXR of the last frame read back from OpenGL; window: screenshot path for 's'");
    cmd->add_option("--stats", a->stats, "Headless: per-frame timings as CSV");
    cmd->add_option("--target-ms", a->targetMs, "Adaptive quality: frame time to hold while interacting")
        ->check(CLI::Range(1.0, 10000.0))
        ->capture_default_str();
    cmd->add_flag("--no-adaptive", a->noAdaptive, "Render every frame at full quality");
    a->raw.add(*cmd);
    cmd->footer("Keys and mouse:\n" + viewer::keyBindingsHelp());
    cmd->callback([a, &global] { runView(*a, global); });
}

} // namespace volcl::cli
