// `volcl view` (the OpenGL viewer, or --headless through EGL) and `volcl bench view` (adaptive-quality
// orbit).
#include "core/Error.hpp"
#include "apps/cli/CliParsing.hpp"
#include "apps/cli/Commands.hpp"
#include "apps/cli/SceneFlags.hpp"
#include "core/AtomicFile.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "host/tf/TransferFunction.hpp"
#include "apps/viewer/ClGlSharing.hpp"
#include "apps/viewer/GlPresenter.hpp"
#include "apps/viewer/HeadlessGl.hpp"
#include "apps/viewer/ViewerApp.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

namespace volcl::cli {
namespace {

struct ViewArgs {
    std::string input, output, stats, keys, transport = "auto";
    SceneFlags scene;
    int frames = 1;
    double orbit = 0.0, targetMs = 100.0;
    bool headless = false, noAdaptive = false, overlay = false, noOverlay = false;
};

bool isSceneFile(const std::filesystem::path& p) {
    std::string ext = p.extension().string();
    for (char& c : ext)
        c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext == ".json";
}

std::string statsCsv(const std::vector<viewer::FrameRecord>& frames) {
    std::ostringstream os;
    os << "frame,interactive,width,height,step,setup_ms,render_ms,kernel_ms,upload_ms,present_ms,frame_ms\n";
    for (const auto& f : frames)
        os << f.index << ',' << (f.interactive ? 1 : 0) << ',' << f.width << ',' << f.height << ',' << f.step
           << ',' << f.setupMs << ',' << f.renderMs << ',' << f.kernelMs << ',' << f.uploadMs << ','
           << f.presentMs << ',' << f.frameMs << '\n';
    return os.str();
}

/// The scene from the positional input (scene JSON or volume) and the scene flags.
Scene viewScene(ViewArgs a) {
    if (!a.input.empty()) {
        if (isSceneFile(a.input)) {
            if (!a.scene.scene.empty()) throw UsageError("view: give the scene once (positional or --scene)");
            a.scene.scene = a.input;
        } else {
            if (!a.scene.volume.empty())
                throw UsageError("view: give the volume once (positional or --volume)");
            a.scene.volume = a.input;
        }
    }
    return a.scene.build(/*requireTf=*/false);
}

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

    ViewerSetup(const ViewArgs& a, const GlobalOptions& global, bool headless) {
        scene = viewScene(a);
        if (!a.output.empty() && headless) checkNotSameFile(scene.volume, a.output);
        const viewer::TransportRequest request = viewer::parseTransportRequest(a.transport);
        std::vector<std::string> notes;
        std::vector<std::filesystem::path> inputs;
        input = a.scene.readSceneInput(scene, notes, &inputs);
        if (!a.output.empty() && headless) checkNotSameFile(inputs, {std::filesystem::path(a.output)});
        for (auto& note : a.scene.finish(scene, *input))
            notes.push_back(std::move(note));
        if (!global.quiet)
            for (const auto& note : notes)
                std::cerr << "view: " << note << '\n';
        if (!scene.tf.empty()) tf = a.scene.loadTf(scene, *input);
        cc = std::make_unique<ComputeContext>(global.device);
        transport = viewer::chooseTransport(request, cc->device());
        if (headless)
            headlessGl = std::make_unique<viewer::HeadlessGlContext>();
        else
            window = std::make_unique<viewer::ViewerWindow>(scene.width, scene.height);
        if (transport == viewer::FrameTransport::ClGlSharing) {
            cc.reset(); // one context per device at a time: the shared one replaces the probe
            try {
                cc = std::make_unique<ComputeContext>(global.device, viewer::glSharingContextProperties());
            } catch (const Error& e) {
                // A driver may list the extension yet refuse this GL context (another GPU, another API):
                // auto falls back to the copy path, share reports why.
                if (request == viewer::TransportRequest::Share) throw;
                if (!global.quiet)
                    std::cerr << "view: no OpenCL context sharing with this OpenGL context (" << e.what()
                              << "); using the pixel buffer object\n";
                transport = viewer::FrameTransport::Pbo;
                cc = std::make_unique<ComputeContext>(global.device);
            }
        }
        viewer::AdaptiveQualityOptions adaptive;
        adaptive.enabled = !a.noAdaptive;
        adaptive.targetMs = a.targetMs;
        session = std::make_unique<viewer::ViewerSession>(*cc, *input, scene, tf, scene.tf, adaptive);
        if (!global.quiet)
            std::cerr << "view: device " << cc->device().name << "; frames reach OpenGL through "
                      << viewer::frameTransportName(transport)
                      << (viewer::availableTransport(cc->device()) == viewer::FrameTransport::Pbo
                              ? " (the device has no cl_khr_gl_sharing)"
                              : (transport == viewer::FrameTransport::Pbo
                                     ? " (sharing refused by --transport)"
                                     : ""))
                      << '\n';
    }
};

viewer::HeadlessOptions headlessOptions(const ViewArgs& a, const ViewerSetup& s, bool quiet) {
    viewer::HeadlessOptions h;
    h.width = s.scene.width;
    h.height = s.scene.height;
    h.frames = a.frames;
    h.orbitDegrees = a.orbit;
    h.keys = a.keys;
    h.output = a.output;
    h.transport = s.transport;
    h.overlay = a.overlay;
    h.quiet = quiet;
    return h;
}

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

// ---- bench view ------------------------------------------------------------------------------------------

struct BenchViewArgs {
    ViewArgs view;
    int stills = 3;
    std::string csv, json;
};

void runBenchView(BenchViewArgs b, const GlobalOptions& global) {
    ViewArgs& a = b.view;
    a.headless = true;
    // The figure is at 512x512 whatever the scene says; --width/--height choose another size.
    if (!a.scene.width) a.scene.width = 512;
    if (!a.scene.height) a.scene.height = 512;
    if (!b.csv.empty()) checkNotSameFile(a.input.empty() ? a.scene.volume : a.input, b.csv);
    if (!b.json.empty()) checkNotSameFile(a.input.empty() ? a.scene.volume : a.input, b.json);
    ViewerSetup s(a, global, true);
    viewer::HeadlessOptions h = headlessOptions(a, s, true);
    h.output.clear();
    // The orbit: a full-quality frame, `frames - 2` interactive frames, a full-quality frame, then the still
    // frames. The first frame also pays for GL shader compilation, so the still figures leave it out.
    h.stillFrames = b.stills;
    const viewer::HeadlessResult orbit = viewer::runHeadless(*s.session, h, *s.headlessGl, std::cerr);
    const std::vector<viewer::FrameRecord>& frames = orbit.frames;
    std::vector<double> inter, interUpload, interRender, interPresent, stillMs, stillUpload, stillRender,
        stillPresent;
    int within = 0, rebuilds = 0;
    for (const auto& f : frames) {
        if (f.interactive) {
            inter.push_back(f.frameMs);
            interUpload.push_back(f.uploadMs);
            interRender.push_back(f.renderMs);
            interPresent.push_back(f.presentMs);
            within += f.frameMs <= 1.1 * a.targetMs ? 1 : 0;
            rebuilds += f.setupMs > 0.1 * a.targetMs ? 1 : 0; // a step change re-plans (setScene)
        } else if (f.index > 0) {
            stillMs.push_back(f.frameMs);
            stillUpload.push_back(f.uploadMs);
            stillRender.push_back(f.renderMs);
            stillPresent.push_back(f.presentMs);
        }
    }
    const auto med = [](const std::vector<double>& v) { return viewer::percentile(v, 50); };
    nlohmann::json j;
    j["device"] = s.cc->device().name;
    j["gl"] = orbit.gl;
    j["transport"] = std::string(viewer::frameTransportName(s.transport));
    j["viewport"] = {s.scene.width, s.scene.height};
    j["step"] = s.scene.step;
    j["target_ms"] = a.targetMs;
    j["adaptive"] = !a.noAdaptive;
    j["interactive_frames"] = inter.size();
    j["interactive_median_ms"] = med(inter);
    j["interactive_p90_ms"] = viewer::percentile(inter, 90);
    j["fraction_within_target_plus_10pct"] = inter.empty() ? 0.0 : double(within) / double(inter.size());
    j["step_change_frames"] = rebuilds;
    j["interactive_upload_median_ms"] = med(interUpload);
    j["interactive_render_median_ms"] = med(interRender);
    j["interactive_present_median_ms"] = med(interPresent);
    j["still_frames"] = stillMs.size();
    j["still_median_ms"] = med(stillMs);
    j["still_upload_median_ms"] = med(stillUpload);
    j["still_render_median_ms"] = med(stillRender);
    j["still_present_median_ms"] = med(stillPresent);
    j["compiled"] = s.session->compiledSummary();

    if (!b.csv.empty()) {
        AtomicFile out(b.csv);
        out.write(statsCsv(frames));
        out.commit();
    }
    if (!b.json.empty()) {
        AtomicFile out(b.json);
        out.write(j.dump(2) + "\n");
        out.commit();
    }
    char line[512];
    std::printf("bench view: %s, %dx%d, step %g, %s; device %s; GL %s\n",
                s.session->compiledSummary().c_str(), s.scene.width, s.scene.height, s.scene.step,
                std::string(viewer::frameTransportName(s.transport)).c_str(), s.cc->device().name.c_str(),
                orbit.gl.c_str());
    if (!inter.empty()) {
        std::snprintf(
            line, sizeof line,
            "interactive (%zu frames, target %.0f ms%s): median %.1f ms, p90 %.1f ms, within target+10%% "
            "%.0f%% (%d of %zu); frames with a step change (setScene over 10%% of the target) %d\n",
            inter.size(), a.targetMs, a.noAdaptive ? ", adaptive off" : "", med(inter),
            viewer::percentile(inter, 90), 100.0 * within / double(inter.size()), within, inter.size(),
            rebuilds);
        std::fputs(line, stdout);
        std::snprintf(line, sizeof line,
                      "interactive transport: upload median %.2f ms vs render median %.2f ms (ratio %.3f); "
                      "upload + draw median %.2f ms\n",
                      med(interUpload), med(interRender),
                      med(interRender) > 0 ? med(interUpload) / med(interRender) : 0.0, med(interPresent));
        std::fputs(line, stdout);
    }
    std::snprintf(
        line, sizeof line,
        "full-quality still (%zu frames): median %.1f ms; upload median %.2f ms vs render median %.1f ms "
        "(ratio %.4f); upload + draw median %.2f ms\n",
        stillMs.size(), med(stillMs), med(stillUpload), med(stillRender),
        med(stillRender) > 0 ? med(stillUpload) / med(stillRender) : 0.0, med(stillPresent));
    std::fputs(line, stdout);
    if (!inter.empty() && med(stillMs) > 0) {
        std::snprintf(line, sizeof line, "interactive median / still median: %.4f\n",
                      med(inter) / med(stillMs));
        std::fputs(line, stdout);
    }
}

void addViewFlags(CLI::App* cmd, ViewArgs& a) {
    a.scene.add(cmd, "--start-orbit");
    cmd->add_option("--target-ms", a.targetMs, "Adaptive quality: frame time to hold while interacting")
        ->check(CLI::Range(1.0, 10000.0))
        ->capture_default_str();
    cmd->add_flag("--no-adaptive", a.noAdaptive, "Render every frame at full quality");
    cmd->add_option("--transport", a.transport,
                    "How frames reach OpenGL: auto (sharing when the device lists cl_khr_gl_sharing), pbo, "
                    "share")
        ->capture_default_str();
    cmd->add_option("--keys", a.keys,
                    "Headless: key actions to apply first, e.g. \"1m\" (see the list below)");
}

} // namespace

void addViewCommand(CLI::App& app, CLI::App& bench, GlobalOptions& global) {
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
    cmd->add_option("--orbit", a->orbit,
                    "Headless: degrees to orbit before each frame in between (interaction)");
    cmd->add_option(
        "-o,--output", a->output,
        "Headless: PNG/EXR of the last frame read back from OpenGL; window: screenshot path for 's'");
    cmd->add_option("--stats", a->stats, "Headless: per-frame timings as CSV");
    cmd->add_flag("--overlay", a->overlay, "Headless: draw the text overlay into the frame (off by default)");
    cmd->add_flag("--no-overlay", a->noOverlay,
                  "Window: start with the text overlay hidden ('o' toggles it)");
    cmd->footer("Keys and mouse:\n" + viewer::keyBindingsHelp());
    cmd->callback([a, &global] { runView(*a, global); });

    auto* b = bench.add_subcommand(
        "view",
        "Viewer: adaptive-quality orbit (headless EGL), frame times against the target, transport cost");
    auto ba = std::make_shared<BenchViewArgs>();
    ba->view.frames = 62;
    ba->view.orbit = 3.0;
    b->add_option("input", ba->view.input, "Scene JSON, or a volume file (then give --tf)");
    addViewFlags(b, ba->view);
    b->add_option("--frames", ba->view.frames, "Orbit frames: the first and last are full quality")
        ->check(CLI::Range(3, 100000))
        ->capture_default_str();
    b->add_option("--orbit", ba->view.orbit, "Degrees of yaw before each interactive frame")
        ->capture_default_str();
    b->add_option(
         "--stills", ba->stills,
         "Full-quality frames after the orbit (the still frame time is their median with the orbit's last)")
        ->check(CLI::Range(0, 1000))
        ->capture_default_str();
    b->add_option("--csv", ba->csv, "Per-frame CSV (orbit, then the stills)");
    b->add_option("--json", ba->json, "Summary JSON");
    b->callback([ba, &global] { runBenchView(*ba, global); });
}

} // namespace volcl::cli
