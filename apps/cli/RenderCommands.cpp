// `volcl render`: a scene and flag overrides to EXR/PNG, or --explain.
#include "apps/cli/CliParsing.hpp"
#include "apps/cli/Commands.hpp"
#include "apps/cli/SceneFlags.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/Timing.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/NiftiMetadata.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/BudgetPlanner.hpp"
#include "render/EffectCosts.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"
#include "render/VolumeRenderer.hpp"
#include "render/grid/ChannelRenderer.hpp"
#include "wavelet/Codec.hpp"

#include <array>
#include <cctype>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>

namespace volcl::cli {

namespace {

std::string outputExtension(const std::filesystem::path& out) {
    std::string ext = out.extension().string();
    for (auto& c : ext)
        c = char(std::tolower(static_cast<unsigned char>(c)));
    if (ext != ".exr" && ext != ".png")
        throw UsageError(out.string() +
                         ": output must be .exr (linear associated RGBA) or .png (sRGB over background)");
    return ext;
}

void writeRendered(const ImageBuffer& img, const std::filesystem::path& out, const Scene& s, bool half) {
    if (outputExtension(out) == ".exr") {
        writeImage(img, out, {.halfFloat = half});
    } else {
        writeImage(compositeOverSrgb(img, s.background), out);
    }
}

// A multi-channel scene ("channels", "color": "direct"): every channel through the channel renderer.
void renderChannels(const Scene& scene, const SceneFlags& flags, const std::string& out, bool half,
                    const GlobalOptions& global) {
    if (out.empty()) throw UsageError("render: --explain does not describe multi-channel scenes; give -o");
    if (scene.volume.extension() == ".vcz")
        throw UsageError(scene.volume.string() + ": multi-channel scenes read grid files, not .vcz");
    const ChannelVolume cv = readSceneChannels(scene, flags.raw.toReadOptions());
    for (const SceneChannel& c : scene.channels)
        if (!c.volume.empty()) checkNotSameFile(c.volume, out);
    Scene s = scene;
    std::vector<std::string> notes;
    for (auto& note : flags.finish(s, RenderInput::borrow(cv.channels.front())))
        notes.push_back(std::move(note));
    const double unit = RenderInput::borrow(cv.channels.front()).approximateCellLength();
    const ChannelStyle style = sceneChannelStyle(s, cv, unit);
    ComputeContext cc(global.device);
    ChannelRenderer r(cc, cv, style, s);
    const ImageBuffer img = r.render();
    writeRendered(img, out, s, half);
    if (!global.quiet) {
        for (const auto& note : notes)
            std::cerr << "volcl render: " << note << '\n';
        std::cerr << "volcl render: " << s.width << "x" << s.height << " " << cv.count() << " channels, "
                  << channelBlendName(style.blend) << ", step " << s.step << ": " << std::fixed
                  << std::setprecision(1) << r.lastMilliseconds() << " ms kernel -> " << out << '\n';
    }
}

} // namespace

void addRenderCommands(CLI::App& app, GlobalOptions& global) {
    auto* cmd = app.add_subcommand(
        "render",
        "Ray-march a volume or ray-cast a tetrahedral mesh: dvr, mip, iso, xray or emission, to EXR or PNG");
    struct Args {
        SceneFlags scene;
        std::string out;
        bool explain = false, half = false, stats = false;
        double budgetMs = 0.0;
    };
    auto a = std::make_shared<Args>();
    a->scene.add(cmd);
    cmd->add_flag(
        "--stats", a->stats,
        "Print the renderer's statistics to stderr (compressed inputs: bricks visited, decoded, cache "
        "hits and misses, bytes decoded, peak cache size)");
    cmd->add_option("-o,--output", a->out,
                    ".exr (linear associated RGBA, + Z with iso-surfaces) or .png (sRGB)");
    cmd->add_flag("--explain", a->explain,
                  "Print the effects compiled into the kernel and why others were dropped");
    cmd->add_flag("--half", a->half, "EXR: store half floats");
    cmd->add_option(
        "--budget-ms", a->budgetMs,
        "Frame-time budget (kernel ms): the scattering order, samples per pixel or step are chosen to fit "
        "it (render.budget_ms)");
    cmd->callback([a, &global] {
        if (a->out.empty() && !a->explain) throw UsageError("render: give -o/--output (or --explain)");
        Scene scene = a->scene.build();
        if (a->budgetMs != 0.0) scene.budgetMs = a->budgetMs; // checked with the scene by the renderer
        if (!a->out.empty()) {
            // Refuse a bad output name or directory before any work: nothing is read or rendered.
            outputExtension(a->out);
            checkOutputPath(a->out);
            checkNotSameFile(scene.volume, a->out);
        }
        if (scene.multiChannel()) {
            try {
                return renderChannels(scene, a->scene, a->out, a->half, global);
            } catch (const UsageError& e) {
                throw a->scene.namingSceneFile(e);
            }
        }
        const std::vector<IsoLayer> isosAsGiven = scene.effects.isosurfaces; // data units
        std::vector<std::string> notes;
        std::vector<std::filesystem::path> inputs;
        // A .vcz renders from its compressed bricks: only its header and index are read here, and the
        // geometry stand-in below is never touched (untouched zero pages).
        std::optional<RenderInput> bricks;
        Volume v; // a .vcz: its geometry only (finish() and loadTf() read the box and spacing)
        std::array<double, 2> dataRange{0, 0};
        struct LinearScale {
            double slope, inter;
            double toData(double stored) const { return stored * slope + inter; }
            double toStored(double data) const { return (data - inter) / slope; }
        };
        std::optional<LinearScale> storedScale;
        if (scene.volume.extension() == ".vcz") {
            bricks = RenderInput::openVcz(scene.volume, a->scene.frame.value_or(0));
            const VczHeader& h = bricks->bricks()->header();
            if (!a->scene.frame && h.frames.size() > 1)
                notes.push_back("rendering frame 0 of " + std::to_string(h.frames.size()) +
                                " (--frame K picks another)");
            inputs = {scene.volume};
            v = Volume(h.dims, h.type);
            v.spacing = h.spacing;
            v.origin = h.origin;
            const auto nifti = placeAsVczSource(v, h, scene.volume.string());
            const ValueRange r = bricks->valueRange();
            dataRange = {r.min, r.max};
            // The stored integers of a scaled NIfTI render in data units, as the .nii itself does: the
            // transfer function, --window and --iso are data units, mapped here onto the stored values.
            if (nifti && nifti->storedValues) {
                storedScale = {nifti->meta.sclSlope, nifti->meta.sclInter};
                if (!(storedScale->slope > 0))
                    throw UsageError(scene.volume.string() + ": scl_slope " +
                                     formatNumber(storedScale->slope) +
                                     " is negative: decode it (volcl decode -o x.nii) to render it");
                dataRange = {storedScale->toData(r.min), storedScale->toData(r.max)};
                if (scene.window)
                    scene.window = std::array<double, 2>{storedScale->toStored((*scene.window)[0]),
                                                         (*scene.window)[1] / storedScale->slope};
                for (IsoLayer& iso : scene.effects.isosurfaces)
                    iso.value = storedScale->toStored(iso.value);
            }
        }
        std::optional<RenderInput> opened; // every other input: a grid or a mesh
        if (!bricks) opened = a->scene.readSceneInput(scene, notes, &inputs);
        if (!a->out.empty()) checkNotSameFile(inputs, {std::filesystem::path(a->out)});
        for (auto& note : bricks ? a->scene.finish(scene, v) : a->scene.finish(scene, *opened))
            notes.push_back(std::move(note));
        if (!isosAsGiven.empty()) {
            // An iso value no voxel reaches draws nothing: say so instead of writing an empty image silently.
            const ValueRange r = bricks ? ValueRange{dataRange[0], dataRange[1]} : opened->valueRange();
            for (const IsoLayer& iso : isosAsGiven)
                if (iso.value < r.min || iso.value > r.max)
                    notes.push_back("iso value " + formatNumber(iso.value) + " is outside the data range [" +
                                    formatNumber(r.min) + ", " + formatNumber(r.max) + "] of " +
                                    scene.volume.string() + ": that surface is empty");
        }
        TransferFunction tf =
            bricks ? a->scene.loadTf(scene, v, dataRange, &notes) : a->scene.loadTf(scene, *opened, &notes);
        if (storedScale)
            tf = tf.rescaled({storedScale->toStored(tf.domain[0]), storedScale->toStored(tf.domain[1])});
        // Notes go to stderr only once the command succeeded: an error stays the one line on stderr.
        auto printNotes = [&] {
            if (!global.quiet)
                for (const auto& note : notes)
                    std::cerr << "volcl render: " << note << '\n';
        };
        if (a->explain)
            for (const auto& note : notes)
                std::cout << "default: " << note << '\n';
        const RenderInput input = bricks ? std::move(*bricks) : std::move(*opened);
        ComputeContext cc(global.device);
        // The renderer's data errors (a cubic filter on NaN voxels, ...) name the input: one line, exit 1.
        // Its usage errors (a step past the samples-per-frame budget, ...) name the scene file the
        // values came from, when there is one: exit 2.
        auto namingInput = [&](auto&& run) -> decltype(run()) {
            try {
                return run();
            } catch (const DataError& e) {
                const std::string what = e.what(), name = scene.volume.string();
                if (what.rfind(name, 0) == 0) throw;
                throw DataError(name + ": " + what);
            } catch (const UsageError& e) {
                throw a->scene.namingSceneFile(e);
            }
        };
        const std::unique_ptr<VolumeRenderer> renderer =
            namingInput([&] { return input.makeRenderer(cc, tf, scene); });
        VolumeRenderer& r = *renderer;
        if (a->explain) std::cout << r.plan().explain() << r.statistics() << '\n';
        std::string budgetText; // the budget's choice, printed with the notes after success
        if (scene.budgetMs > 0.0) {
            const BudgetChoice choice = fitBudget(r, scene.budgetMs, budgetKnobs(r, scene));
            scene = r.scene();
            if (a->explain)
                std::cout << choice.text();
            else
                budgetText = choice.text();
        }
        if (a->explain) std::cout << measureEffectCosts(r).text();
        if (a->out.empty()) {
            printNotes();
            return;
        }
        const ImageBuffer img = namingInput([&] { return r.render(); });
        writeRendered(img, a->out, scene, a->half);
        printNotes();
        std::cerr << budgetText;
        if (a->stats) std::cerr << "volcl render: " << r.statistics() << '\n';
        if (!global.quiet)
            std::cerr << "volcl render: " << scene.width << "x" << scene.height << " "
                      << renderModeName(scene.mode) << ", step " << scene.step << ": " << std::fixed
                      << std::setprecision(1) << r.lastKernelMilliseconds() << " ms kernel"
                      << (r.lastTableMilliseconds() > 0
                              ? ", table " + std::to_string(int(r.lastTableMilliseconds())) + " ms"
                              : "")
                      << " -> " << a->out << '\n';
    });
}

} // namespace volcl::cli
