// What `volcl view` and `volcl bench view` share: the viewer's flags, the setup of OpenCL, OpenGL and the
// session in the order context sharing needs, headless options and the per-frame CSV.
#include "apps/cli/ViewSetup.hpp"

#include "apps/cli/CliParsing.hpp"
#include "apps/viewer/ClGlSharing.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"

#include <cctype>
#include <iostream>
#include <sstream>

namespace volcl::cli {

namespace {

bool isSceneFile(const std::filesystem::path& p) {
    std::string ext = p.extension().string();
    for (char& c : ext)
        c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext == ".json";
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
    return a.scene.build();
}

} // namespace

std::string statsCsv(const std::vector<viewer::FrameRecord>& frames) {
    std::ostringstream os;
    os << "frame,interactive,width,height,step,setup_ms,render_ms,kernel_ms,upload_ms,present_ms,frame_ms\n";
    for (const auto& f : frames)
        os << f.index << ',' << (f.interactive ? 1 : 0) << ',' << f.width << ',' << f.height << ',' << f.step
           << ',' << f.setupMs << ',' << f.renderMs << ',' << f.kernelMs << ',' << f.uploadMs << ','
           << f.presentMs << ',' << f.frameMs << '\n';
    return os.str();
}

ViewerSetup::ViewerSetup(const ViewArgs& a, const GlobalOptions& global, bool headless) {
    scene = viewScene(a);
    if (!a.output.empty() && headless) checkNotSameFile(scene.volume, a.output);
    const viewer::TransportRequest request = viewer::parseTransportRequest(a.transport);
    std::vector<std::string> notes;
    std::vector<std::filesystem::path> inputs;
    input = a.scene.readSceneInput(scene, notes, &inputs);
    if (!a.output.empty() && headless) checkNotSameFile(inputs, {std::filesystem::path(a.output)});
    for (auto& note : a.scene.finish(scene, *input))
        notes.push_back(std::move(note));
    tf = a.scene.loadTf(scene, *input, &notes); // the scene's, or ParaView's default as `volcl render`'s
    if (!global.quiet)
        for (const auto& note : notes)
            std::cerr << "view: " << note << '\n';
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
    adaptive.previewTiers = !a.noPreviewTiers;
    adaptive.targetMs = a.targetMs;
    session = std::make_unique<viewer::ViewerSession>(*cc, *input, scene, tf, scene.tf, adaptive);
    if (!global.quiet)
        std::cerr << "view: device " << cc->device().name << "; frames reach OpenGL through "
                  << viewer::frameTransportName(transport)
                  << (viewer::availableTransport(cc->device()) == viewer::FrameTransport::Pbo
                          ? " (the device has no cl_khr_gl_sharing)"
                          : (transport == viewer::FrameTransport::Pbo ? " (sharing refused by --transport)"
                                                                      : ""))
                  << '\n';
}

viewer::HeadlessOptions headlessOptions(const ViewArgs& a, const ViewerSetup& s, bool quiet) {
    viewer::HeadlessOptions h;
    h.width = s.scene.width;
    h.height = s.scene.height;
    h.frames = a.frames;
    h.orbitDegrees = a.spin;
    h.keys = a.keys;
    h.output = a.output;
    h.transport = s.transport;
    h.overlay = a.overlay;
    h.quiet = quiet;
    return h;
}

void addViewFlags(CLI::App* cmd, ViewArgs& a) {
    a.scene.add(cmd);
    cmd->add_option("--target-ms", a.targetMs, "Adaptive quality: frame time to hold while interacting")
        ->check(CLI::Range(1.0, 10000.0))
        ->capture_default_str();
    cmd->add_flag("--no-adaptive", a.noAdaptive, "Render every frame at full quality");
    cmd->add_flag("--no-preview-tiers", a.noPreviewTiers,
                  "While the view moves, coarsen the ray marcher instead of rendering grids with shear-warp "
                  "(orthographic) or discrete ray casting (perspective)");
    cmd->add_option("--transport", a.transport,
                    "How frames reach OpenGL: auto (sharing when the device lists cl_khr_gl_sharing), pbo, "
                    "share")
        ->capture_default_str();
    cmd->add_option("--keys", a.keys,
                    "Headless: key actions to apply first, e.g. \"1m\" (see the list below)");
}

} // namespace volcl::cli
