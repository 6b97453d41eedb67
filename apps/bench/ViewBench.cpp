// `volcl bench view`: the viewer's adaptive-quality orbit (headless EGL), frame times against the target and
// the cost of moving frames to OpenGL.
#include "apps/bench/BenchCommand.hpp"

#include "apps/cli/CliParsing.hpp"
#include "apps/cli/ViewSetup.hpp"
#include "core/AtomicFile.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <iostream>
#include <memory>

namespace volcl::cli {
namespace {

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

} // namespace

void addViewBench(CLI::App& bench, GlobalOptions& global) {
    auto* b = bench.add_subcommand(
        "view",
        "Viewer: adaptive-quality orbit (headless EGL), frame times against the target, transport cost");
    auto ba = std::make_shared<BenchViewArgs>();
    ba->view.frames = 62;
    ba->view.spin = 3.0;
    b->add_option("input", ba->view.input, "Scene JSON, or a volume file (then give --tf)");
    addViewFlags(b, ba->view);
    b->add_option("--frames", ba->view.frames, "Orbit frames: the first and last are full quality")
        ->check(CLI::Range(3, 100000))
        ->capture_default_str();
    b->add_option("--spin", ba->view.spin, "Degrees of yaw before each interactive frame")
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
