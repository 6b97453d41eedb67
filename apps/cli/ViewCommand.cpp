// `volcl view`: the OpenGL viewer, or --headless through EGL.
#include "apps/cli/Commands.hpp"
#include "apps/cli/ViewSetup.hpp"
#include "core/AtomicFile.hpp"

#include <cstdio>
#include <iostream>
#include <memory>

namespace volcl::cli {
namespace {

void runView(const ViewArgs& a, const GlobalOptions& global) {
    ViewerSetup s(a, global, a.headless);
    if (!a.headless) {
        viewer::WindowOptions w;
        w.width = s.scene.width;
        w.height = s.scene.height;
        if (!a.output.empty()) w.screenshot = a.output;
        w.transport = s.transport;
        w.overlay = !a.noOverlay;
        w.quiet = global.quiet;
        viewer::runWindow(*s.session, w, *s.window, std::cerr);
        return;
    }
    const viewer::HeadlessResult r =
        viewer::runHeadless(*s.session, headlessOptions(a, s, global.quiet), *s.headlessGl, std::cerr);
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
        std::snprintf(
            line, sizeof line,
            "view: full-quality frame %dx%d step %g: %.1f ms (render %.1f, kernel %.1f, upload %.1f, "
            "present %.1f)\n",
            last.width, last.height, last.step, last.frameMs, last.renderMs, last.kernelMs, last.uploadMs,
            last.presentMs);
        std::cerr << line;
        std::cerr << "view: compiled: " << s.session->compiledSummary() << '\n';
    }
}

} // namespace

void addViewCommand(CLI::App& app, GlobalOptions& global) {
    auto* cmd = app.add_subcommand(
        "view", "Interactive OpenGL viewer of the ray marcher (or --headless through EGL)");
    auto a = std::make_shared<ViewArgs>();
    cmd->add_option("input", a->input,
                    "Scene JSON, or a volume file (then give --tf); or use --scene/--volume");
    addViewFlags(cmd, *a);
    cmd->add_flag("--headless", a->headless, "No window: render through an EGL offscreen context");
    cmd->add_option("--frames", a->frames, "Headless: frames to render; the first and last are full quality")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    cmd->add_option("--spin", a->spin,
                    "Headless: degrees of yaw the camera turns before each frame in between (interaction); "
                    "--orbit AZ,EL places the camera as in render");
    cmd->add_option(
        "-o,--output", a->output,
        "Headless: PNG/EXR of the last frame read back from OpenGL; window: screenshot path for 's'");
    cmd->add_option("--stats", a->stats, "Headless: per-frame timings as CSV");
    cmd->add_flag("--overlay", a->overlay, "Headless: draw the text overlay into the frame (off by default)");
    cmd->add_flag("--no-overlay", a->noOverlay,
                  "Window: start with the text overlay hidden ('o' toggles it)");
    cmd->footer("Keys and mouse:\n" + viewer::keyBindingsHelp());
    cmd->callback([a, &global] { runView(*a, global); });
}

} // namespace volcl::cli
