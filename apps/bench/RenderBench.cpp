// `volcl bench render`: the ray marcher's accuracy against time (step x pre-integration x skipping), effect
// costs, tables, fog, filters, scattering, budgets, and VTK's ray caster as a peer; meshes go to
// MeshBench.cpp.
#include "apps/bench/BenchCommand.hpp"

#include "apps/bench/BenchPaths.hpp"
#include "apps/bench/BudgetBench.hpp"
#include "apps/bench/FilterBench.hpp"
#include "apps/bench/MediaBench.hpp"
#include "apps/bench/MeshBench.hpp"
#include "apps/bench/ScatterBench.hpp"
#include "apps/bench/ShadingBench.hpp"
#include "apps/bench/ShadowBench.hpp"
#include "apps/bench/SkipBench.hpp"
#include "apps/bench/TierBench.hpp"
#include "apps/bench/VtkPeer.hpp"
#include "apps/cli/CliParsing.hpp"
#include "apps/cli/SceneFlags.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/Timing.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "meshcodec/MeshCodec.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"
#include "render/VolumeRenderer.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include <unistd.h>

namespace volcl::cli {

double rmseRgb(const ImageBuffer& a, const ImageBuffer& b) {
    double sum = 0.0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = 0; c < 3; ++c) {
                const double d = double(a.at(x, y, c)) - double(b.at(x, y, c));
                sum += d * d;
            }
    return std::sqrt(sum / (3.0 * a.width * a.height));
}

double timeFrames(VolumeRenderer& r, int runs) {
    r.render();
    std::vector<double> ms;
    for (int i = 0; i < runs; ++i) {
        r.render();
        ms.push_back(r.lastKernelMilliseconds());
    }
    return median(ms);
}

namespace {

struct BenchArgs {
    SceneFlags scene;
    std::string steps = "0.25,0.5,1,2";
    int runs = 5;
    double referenceStep = 0.05;
    std::string csv, vtkImage;
    bool effects = false, vtk = false, sweep = true, filters = false, tables = false, fog = false;
    bool gradientTf = false;
    std::string gradientTfCsv, gradientTfPeer;
    bool scattering = false, tiers = false, shadows = false;
    TierBenchOptions tier;
    bool skipSweep = false;
    std::string skipCsv;
    bool shading = false;
    std::string shadingCsv, shadingGradients = "cache,cache-nearest,central,sobel";
    ScatterBenchOptions scatter;
    ShadowBenchOptions shadow;
    std::string shadowCells = "1,2,4", shadowRaySteps = "1,2";
    std::string budgets; ///< --budgets: frame-time budgets in ms
    BudgetBenchOptions budget;
    std::string meshLengths = "8,16,32,64";
    std::string vtkMappers = "bunyk,projected_tetrahedra,zsweep";
    std::string vtkScript = peerScriptDir() + "/vtk_raycast.py";
};

void benchEffects(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf, Scene base,
                  int runs) {
    base.preintegration = Preintegration::None;
    base.skipping = SkipMode::Off;
    base.effects = {};
    base.lights.clear();
    const std::unique_ptr<VolumeRenderer> renderer = input.makeRenderer(cc, tf, base);
    VolumeRenderer& r = *renderer;
    // Plain kernel from the full source vs the baseline file that never contained any effect, interleaved.
    std::vector<double> plain, baseline;
    r.render();
    r.renderPlainBaseline();
    for (int i = 0; i < std::max(runs, 7); ++i) {
        r.render();
        plain.push_back(r.lastKernelMilliseconds());
        r.renderPlainBaseline();
        baseline.push_back(r.lastKernelMilliseconds());
    }
    const double plainMs = median(plain), baseMs = median(baseline);
    std::cout << "effect cost, " << base.width << "x" << base.height << ", step " << base.step
              << ", median of " << plain.size() << " frames (ms, ratio to plain)\n";
    std::cout << std::fixed << std::setprecision(2);
    std::cout << "  plain (raymarch.cl, no -D effects)      " << std::setw(9) << plainMs << "  1.000\n";
    std::cout << "  baseline (raymarch_plain.cl)            " << std::setw(9) << baseMs << "  "
              << std::setprecision(3) << baseMs / plainMs << "  plain/baseline " << plainMs / baseMs
              << (plainMs <= 1.03 * baseMs ? " (within 3%)" : " (over 3%)") << '\n';
    const WorldBox box = input.bounds();
    const Vec3 centre{box.origin[0] + 0.5 * box.extent[0], box.origin[1] + 0.5 * box.extent[1],
                      box.origin[2] + 0.5 * box.extent[2]};
    const double mid = 0.5 * (tf.domain[0] + tf.domain[1]);
    struct Variant {
        const char* name;
        std::function<void(Scene&)> apply;
    };
    const Light light{LightKind::Directional, {0.4, 0.6, -0.7}, {1, 1, 1}, 1.0};
    const std::vector<Variant> variants = {
        {"shading (1 light, gradient cache)",
         [&](Scene& s) {
             s.lights = {light};
             s.effects.shading = true;
         }},
        {"shading, central differences",
         [&](Scene& s) {
             s.lights = {light};
             s.effects.shading = true;
             s.effects.gradient = GradientKind::Central;
         }},
        {"shading, Sobel gradients",
         [&](Scene& s) {
             s.lights = {light};
             s.effects.shading = true;
             s.effects.gradient = GradientKind::Sobel;
         }},
        {"shading + shadows (shadow rays)",
         [&](Scene& s) {
             s.lights = {light};
             s.effects.shading = true;
             s.effects.shadows = true;
             s.effects.shadowStep = 2.0 * s.step;
             s.effects.shadowMethod = ShadowMethod::Rays;
         }},
        {"shading + shadows (light volume)",
         [&](Scene& s) {
             s.lights = {light};
             s.effects.shading = true;
             s.effects.shadows = true;
             s.effects.shadowStep = 2.0 * s.step;
         }},
        {"single scattering",
         [&](Scene& s) {
             s.lights = {light};
             s.effects.scattering = true;
             s.effects.albedo = 0.7;
             s.effects.phaseG = 0.3;
         }},
        {"multiple scattering (path tracer, 16 spp)",
         [&](Scene& s) {
             s.lights = {light};
             s.effects.scattering = true;
             s.effects.albedo = 0.7;
             s.effects.phaseG = 0.3;
             s.effects.scatteringOrder = ScatteringOrder::Multiple;
             s.effects.samples = 16;
         }},
        {"clipping plane",
         [&](Scene& s) {
             s.effects.clipPlanes = {{{1, 0, 0}, -centre[0]}};
         }},
        {"iso-surface mixed into dvr",
         [&](Scene& s) {
             s.effects.isosurfaces = {{mid, {1, 1, 1, 0.5}}};
         }},
        {"empty-space skipping", [&](Scene& s) { s.skipping = SkipMode::On; }},
        {"2D pre-integration", [&](Scene& s) { s.preintegration = Preintegration::Table2d; }},
        {"3D pre-integration", [&](Scene& s) { s.preintegration = Preintegration::Table3d; }},
        {"fog, constant layer (falloff 0)",
         [&](Scene& s) {
             s.effects.fog.enabled = true;
             s.effects.fog.density = 0.01;
             s.effects.fog.base = centre[1];
         }},
        {"fog, exponential layer",
         [&](Scene& s) {
             s.effects.fog.enabled = true;
             s.effects.fog.density = 0.01;
             s.effects.fog.base = box.origin[1] + 0.25 * box.extent[1];
             s.effects.fog.falloff = 0.25 * box.extent[1];
         }},
    };
    for (const auto& var : variants) {
        Scene s = base;
        var.apply(s);
        r.setScene(s);
        const double ms = timeFrames(r, runs);
        std::cout << "  " << std::left << std::setw(40) << var.name << std::right << std::setw(9)
                  << std::setprecision(2) << ms << "  " << std::setprecision(3) << ms / plainMs << "  ["
                  << r.plan().defines.toOptions() << "]\n";
    }
}

/// Runs VTK's vtkFixedPointVolumeRayCastMapper through python3-vtk9 on the same volume, TF, camera, size and
/// sample distance. Returns its median ms per frame and its image (RGB over black, i.e. associated colour).
std::pair<double, ImageBuffer> runVtk(const BenchArgs& a, const Volume& v, const TransferFunction& tf,
                                      const Scene& s, const Camera& cam, const std::filesystem::path& dir) {
    const auto rawPath = dir / "vtk-volume.f32";
    {
        const std::vector<float> f = v.toFloat();
        std::ofstream out(rawPath, std::ios::binary);
        out.write(reinterpret_cast<const char*>(f.data()), std::streamsize(f.size() * sizeof(float)));
        if (!out) throw IoError(rawPath.string() + ": cannot write the VTK input");
    }
    nlohmann::json job;
    job["volume"] = rawPath.string();
    job["dims"] = {v.dims().x, v.dims().y, v.dims().z};
    job["spacing"] = v.spacing;
    job["origin"] = v.origin;
    job["tf"] = vtkTransferFunction(tf);
    job["camera"] = vtkCamera(cam);
    job["width"] = s.width;
    job["height"] = s.height;
    job["step"] = s.step;
    job["shade"] = vtkShading(s);
    job["runs"] = a.runs;
    job["image"] = (dir / "vtk-image.f32").string();
    job["result"] = (dir / "vtk-result.json").string();
    const auto jobPath = dir / "vtk-job.json";
    std::ofstream(jobPath) << job.dump(2);
    runVtkScript(a.vtkScript, jobPath);
    std::ifstream res(dir / "vtk-result.json");
    const nlohmann::json r = nlohmann::json::parse(res);
    return {r.at("median_ms").get<double>(), readVtkImage(dir / "vtk-image.f32", s.width, s.height)};
}

/// `bench render` on a tetrahedral mesh: MeshBench.cpp.
void benchMeshInput(const BenchArgs& a, GlobalOptions& global, Scene scene) {
    std::vector<std::string> notes;
    const RenderInput input = a.scene.readSceneInput(scene, notes);
    for (auto& note : a.scene.finish(scene, input))
        notes.push_back(std::move(note));
    if (!global.quiet)
        for (const auto& note : notes)
            std::cerr << "volcl bench render: " << note << '\n';
    const TransferFunction tf = a.scene.loadTf(scene, input);
    ComputeContext cc(global.device);
    std::cerr << "volcl bench render: " << scene.volume.string() << " " << input.summary() << ", "
              << scene.width << "x" << scene.height << ", device " << cc.device().name << '\n';
    MeshBenchOptions o;
    o.runs = a.runs;
    o.vtk = a.vtk;
    o.vtkScript = peerScriptDir() + "/vtk_mesh.py";
    o.vtkImages = a.vtkImage;
    o.csv = a.csv;
    o.lengths = a.meshLengths;
    o.vtkMappers = a.vtkMappers;
    benchMeshRender(cc, input, tf, scene, o);
}

void benchRender(const BenchArgs& a, GlobalOptions& global) {
    Scene scene = a.scene.build();
    if (meshcodec::isMeshFile(scene.volume)) return benchMeshInput(a, global, scene);
    std::vector<std::string> notes;
    Volume volume = a.scene.readSceneVolume(scene, notes);
    for (auto& note : a.scene.finish(scene, volume))
        notes.push_back(std::move(note));
    if (!global.quiet)
        for (const auto& note : notes)
            std::cerr << "volcl bench render: " << note << '\n';
    const TransferFunction tf = a.scene.loadTf(scene, volume);
    const RenderInput input = RenderInput::fromVolume(std::move(volume));
    ComputeContext cc(global.device);
    std::cerr << "volcl bench render: " << scene.volume.string() << " " << input.summary() << ", "
              << scene.width << "x" << scene.height << ", device " << cc.device().name << '\n';
    if (a.effects) benchEffects(cc, input, tf, scene, a.runs);
    if (a.shading) {
        ShadingBenchOptions o;
        o.runs = a.runs;
        o.csv = a.shadingCsv;
        o.gradients.clear();
        std::stringstream names(a.shadingGradients);
        for (std::string name; std::getline(names, name, ',');)
            o.gradients.push_back(parseGradientKind(name));
        const Volume* g = input.grid();
        o.referenceStep =
            a.referenceStep * (g ? std::min({g->spacing[0], g->spacing[1], g->spacing[2]}) : 1.0);
        if (a.vtk) {
            if (!g) throw UsageError("bench render: --vtk measures grids (give a volume)");
            o.vtk = [&](const Scene& s) {
                const auto dir =
                    std::filesystem::temp_directory_path() / ("volcl-vtk-" + std::to_string(::getpid()));
                std::filesystem::create_directories(dir);
                const Camera cam = input.makeRenderer(cc, tf, s)->camera();
                auto result = runVtk(a, *g, tf, s, cam, dir);
                std::filesystem::remove_all(dir);
                return result;
            };
        }
        benchShading(cc, input, tf, scene, o);
        if (!a.sweep) return; // --vtk ran inside, shaded and plain
    }
    if (a.scattering) {
        ScatterBenchOptions o = a.scatter;
        o.runs = a.runs;
        benchScattering(cc, input, tf, scene, o);
    }
    if (a.shadows) {
        ShadowBenchOptions o = a.shadow;
        o.rounds = a.runs;
        o.cells.clear();
        for (double c : parseNumbers(a.shadowCells, 0, "--light-volume-cells"))
            o.cells.push_back(int(c));
        o.raySteps = parseNumbers(a.shadowRaySteps, 0, "--shadow-ray-steps");
        // A .vcz is measured as `volcl render` draws it, from its compressed bricks (the other sweeps take the
        // decoded grid).
        if (scene.volume.extension() == ".vcz")
            benchShadows(cc, RenderInput::openVcz(scene.volume, a.scene.frame.value_or(0)), tf, scene, o);
        else
            benchShadows(cc, input, tf, scene, o);
    }
    if (!a.budgets.empty()) {
        BudgetBenchOptions o = a.budget;
        o.budgetsMs = parseNumbers(a.budgets, 0, "--budgets");
        o.runs = a.runs;
        o.referenceSamples = a.scatter.referenceSamples;
        benchBudgets(cc, input, tf, scene, o);
    }
    if (a.tiers) {
        TierBenchOptions o = a.tier;
        o.steps = parseNumbers(a.steps, 0, "--steps");
        o.referenceStep = a.referenceStep;
        benchTiers(cc, input, tf, scene, o);
    }
    if (a.skipSweep) {
        const Volume* g = input.grid();
        const double sp = g ? std::min({g->spacing[0], g->spacing[1], g->spacing[2]}) : 1.0;
        SkipBenchOptions o;
        for (double st : parseNumbers(a.steps, 0, "--steps"))
            o.steps.push_back(st * sp);
        o.rounds = a.runs;
        o.csv = a.skipCsv;
        benchSkipping(cc, input, tf, scene, o);
    }
    if (a.filters) benchFilters(cc, input, tf, scene, a.runs, a.sweep || a.vtk ? std::string() : a.csv);
    if (a.gradientTf) {
        const Volume* g = input.grid();
        const double sp = g ? std::min({g->spacing[0], g->spacing[1], g->spacing[2]}) : 1.0;
        std::vector<double> steps;
        for (double st : parseNumbers(a.steps, 0, "--steps"))
            steps.push_back(st * sp);
        const std::optional<TransferFunction> peer =
            a.gradientTfPeer.empty()
                ? std::nullopt
                : std::optional<TransferFunction>(TransferFunction::fromFile(a.gradientTfPeer));
        benchGradientTf(cc, input, tf, peer, scene, steps, a.referenceStep * sp, a.runs, a.gradientTfCsv);
    }
    if (a.tables || a.fog) {
        const Volume* g = input.grid();
        const double sp = g ? std::min({g->spacing[0], g->spacing[1], g->spacing[2]}) : 1.0;
        const std::string out = a.sweep || a.vtk ? std::string() : a.csv;
        if (a.tables) {
            std::vector<double> steps;
            for (double st : parseNumbers(a.steps, 0, "--steps"))
                steps.push_back(st * sp);
            benchTables(cc, input, tf, scene, steps, a.referenceStep * sp, a.runs, out);
        }
        if (a.fog)
            benchFog(cc, input, tf, scene, a.referenceStep * sp, a.runs, a.tables ? std::string() : out);
    }
    if (!a.sweep && !a.vtk) return;
    const Volume* grid = input.grid();
    if (!grid) throw UsageError("bench render: the sweep and --vtk measure grids (give a volume)");
    const Volume& v = *grid;

    // Reference at the same image size: the accuracy every configuration is measured against.
    Stopwatch sw;
    const double minSpacing = std::min({v.spacing[0], v.spacing[1], v.spacing[2]});
    const ImageBuffer ref = input.renderReference(tf, scene, {.step = a.referenceStep * minSpacing});
    std::cerr << "reference (double, step " << a.referenceStep * minSpacing << "): " << std::fixed
              << std::setprecision(1) << sw.milliseconds() / 1000.0 << " s\n";

    std::ostringstream csv;
    csv << "step,preintegration,skipping,ms_per_frame,table_ms,rmse_rgba,rmse_rgb\n";
    if (a.sweep) {
        std::cout << "accuracy vs time, median of " << a.runs
                  << " frames, RMSE against the double reference\n";
        std::cout << std::fixed << "  step   preint  skip   ms/frame   table ms   RMSE rgba    RMSE rgb\n";
        for (double step : parseNumbers(a.steps, 0, "--steps")) {
            for (Preintegration pre :
                 {Preintegration::None, Preintegration::Table2d, Preintegration::Table3d}) {
                for (bool skip : {true, false}) {
                    Scene s = scene;
                    s.step = step * minSpacing;
                    s.preintegration = pre;
                    s.skipping = skip ? SkipMode::On : SkipMode::Off;
                    const std::unique_ptr<VolumeRenderer> r = input.makeRenderer(cc, tf, s);
                    const double tableMs = r->lastTableMilliseconds();
                    const double ms = timeFrames(*r, a.runs);
                    const ImageBuffer img = r->render();
                    const double e4 = imageRmse(img, ref), e3 = rmseRgb(img, ref);
                    std::cout << std::setprecision(3) << "  " << std::setw(5) << step << "  " << std::setw(6)
                              << preintegrationName(pre) << "  " << std::setw(4) << (skip ? "on" : "off")
                              << "  " << std::setw(9) << std::setprecision(2) << ms << "  " << std::setw(9)
                              << tableMs << "  " << std::scientific << std::setprecision(3) << std::setw(10)
                              << e4 << "  " << std::setw(10) << e3 << std::fixed << '\n';
                    csv << step << ',' << preintegrationName(pre) << ',' << (skip ? 1 : 0) << ',' << ms << ','
                        << tableMs << ',' << e4 << ',' << e3 << '\n';
                }
            }
        }
    }
    if (a.vtk) {
        const auto dir = std::filesystem::temp_directory_path() / ("volcl-vtk-" + std::to_string(::getpid()));
        std::filesystem::create_directories(dir);
        const std::unique_ptr<VolumeRenderer> r = input.makeRenderer(cc, tf, scene);
        const auto [vtkMs, vtkImg] = runVtk(a, v, tf, scene, r->camera(), dir);
        std::filesystem::remove_all(dir);
        const double ms = timeFrames(*r, a.runs);
        const double ours = rmseRgb(r->render(), ref), theirs = rmseRgb(vtkImg, ref);
        if (!a.vtkImage.empty()) {
            writeImage(vtkImg, a.vtkImage);
            writeImage(ref, std::filesystem::path(a.vtkImage).replace_extension(".reference.exr"));
        }
        std::cout << "peer comparison, " << scene.width << "x" << scene.height << ", step " << scene.step
                  << ", same volume/TF/camera, RMSE of RGB (associated, over black) against the reference\n";
        std::cout << std::fixed << std::setprecision(2) << "  volcl "
                  << preintegrationName(scene.preintegration)
                  << (scene.skipping != SkipMode::Off ? " +skip" : "") << ": " << ms << " ms/frame, RMSE "
                  << std::scientific << std::setprecision(3) << ours << std::fixed << '\n';
        std::cout << std::setprecision(2) << "  VTK vtkFixedPointVolumeRayCastMapper: " << vtkMs
                  << " ms/frame, RMSE " << std::scientific << std::setprecision(3) << theirs << std::fixed
                  << '\n';
        std::cout << std::setprecision(2) << "  speed ratio VTK/volcl: " << vtkMs / ms << "x\n";
        csv << "# vtk," << vtkMs << ',' << theirs << ",volcl," << ms << ',' << ours << '\n';
    }
    if (!a.csv.empty()) {
        AtomicFile out(a.csv);
        out.write(csv.str());
        out.commit();
    }
}

} // namespace

void addRenderBench(CLI::App& bench, GlobalOptions& global) {
    auto* b = bench.add_subcommand(
        "render", "Ray marcher: error vs time sweep, effect costs, VTK peer (meshes: methods vs "
                  "the exact reference, VTK's Bunyk, projected tetrahedra, ZSweep)");
    auto ba = std::make_shared<BenchArgs>();
    ba->scene.add(b);
    b->add_option("--steps", ba->steps, "Steps to sweep, in units of the smallest voxel spacing")
        ->capture_default_str();
    b->add_option("--runs", ba->runs, "Timed frames per configuration (median)")->capture_default_str();
    b->add_option("--reference-step", ba->referenceStep, "Reference step in voxel spacings")
        ->capture_default_str();
    b->add_option("--csv", ba->csv, "Write the sweep as CSV (for bench/plot_render.py)");
    b->add_flag(
        "--tables", ba->tables,
        "Pre-integrated lighting and iso-surface tables against the per-sample paths: time and RMSE vs "
        "the reference per --steps (with --no-sweep, --csv receives these rows)");
    b->add_flag("--fog", ba->fog,
                "Fog (constant and exponential layer) against the plain frame: time ratio and RMSE vs the "
                "reference");
    b->add_flag("--gradient-tf", ba->gradientTf,
                "A gradient TF (--tf with gradient_opacity or widgets): its value axis alone against the "
                "gradient TF at each --steps, interleaved, RMSE vs the reference of each");
    b->add_option("--gradient-tf-csv", ba->gradientTfCsv, "--gradient-tf: write the rows as CSV");
    b->add_option(
        "--gradient-tf-peer", ba->gradientTfPeer,
        "--gradient-tf: a 1D TF (canonical JSON, data units) timed as the peer instead of the gradient "
        "TF's value axis, e.g. the best 1D TF of the same feature");
    b->add_flag(
        "--shading-sweep", ba->shading,
        "Blinn-Phong per gradient kind (cache, cache-nearest, central, sobel) and an iso layer against "
        "the plain frame in interleaved rounds, RMSE vs the reference; with --vtk, VTK shaded and plain");
    b->add_option("--shading-gradients", ba->shadingGradients,
                  "--shading-sweep: gradient kinds of the shaded frames timed (central is rendered once "
                  "anyway, for the RMSE column)")
        ->capture_default_str();
    b->add_option("--shading-csv", ba->shadingCsv,
                  "--shading-sweep: write the rows as CSV (bench/plot_shading.py)");
    b->add_flag("--effects", ba->effects,
                "Cost of each effect alone, and plain vs effect-free baseline kernel");
    b->add_flag(
        "--filters", ba->filters,
        "Reconstruction filters (linear, linear+Sobel, cubic, bspline): time, normal error on an 8-bit "
        "sphere, terrace roughness on the scene (with --no-sweep, --csv receives these rows)");
    b->add_flag("--scatter-sweep", ba->scattering,
                "Single and multiple scattering against a converged path-traced reference: ms/frame, cost "
                "relative to the plain frame, RMSE against samples per pixel");
    b->add_option("--reference-samples", ba->scatter.referenceSamples,
                  "--scatter-sweep, --budgets: samples per pixel of the reference")
        ->capture_default_str();
    b->add_option("--max-samples", ba->scatter.maxSamples,
                  "--scatter-sweep: largest samples per pixel of the sweep")
        ->capture_default_str();
    b->add_option("--scatter-csv", ba->scatter.csv, "--scatter-sweep: write the rows as CSV");
    b->add_flag("--shadow-sweep", ba->shadows,
                "Shadows from light volumes against secondary rays (directional and head light): build time, "
                "interleaved frame times, ratio to the plain frame, RMSE against rays at the first "
                "--shadow-ray-steps");
    b->add_option("--light-volume-cells", ba->shadowCells, "--shadow-sweep: light-volume cell sizes (voxels)")
        ->capture_default_str();
    b->add_option("--shadow-ray-steps", ba->shadowRaySteps,
                  "--shadow-sweep: shadow-ray steps in voxel spacings; the first is the reference")
        ->capture_default_str();
    b->add_option("--shadow-csv", ba->shadow.csv, "--shadow-sweep: write the rows as CSV");
    b->add_flag("--skip-sweep", ba->skipSweep,
                "Empty-space skipping auto/on/off per --steps: medians of --runs interleaved rounds, auto's "
                "choice and auto against the better of on and off");
    b->add_option("--skip-csv", ba->skipCsv, "--skip-sweep: write the rows as CSV");
    b->add_option("--budgets", ba->budgets,
                  "Frame-time budgets in ms (e.g. 400,1000): the planner's choice for each, timed again in "
                  "interleaved rounds, and its RMSE against the reference (--reference-samples)");
    b->add_option("--budget-rounds", ba->budget.rounds, "--budgets: interleaved timing rounds")
        ->capture_default_str();
    b->add_option("--budget-csv", ba->budget.csv, "--budgets: write the rows as CSV");
    b->add_option("--scatter-images", ba->scatter.imageDir,
                  "--scatter-sweep: write every variant's EXR and PNG here");
    b->add_flag("--tiers", ba->tiers,
                "Preview tiers: shear-warp and discrete ray casting against the ray marcher at each --steps, "
                "interleaved, ms and RMSE against the reference");
    b->add_option("--tier-rounds", ba->tier.rounds, "--tiers: interleaved rounds (medians)")
        ->capture_default_str();
    b->add_option("--tier-csv", ba->tier.csv, "--tiers: write the rows as CSV (bench/render/plot_tiers.py)");
    b->add_flag("--vtk", ba->vtk, "Compare with VTK's vtkFixedPointVolumeRayCastMapper (python3-vtk9, xvfb)");
    b->add_flag("!--no-sweep", ba->sweep, "Skip the step x pre-integration x skipping sweep");
    b->add_option(
        "--vtk-image", ba->vtkImage,
        "Save VTK's image (EXR) and the reference beside it (meshes: a folder for every peer's image)");
    b->add_option("--mesh-lengths", ba->meshLengths,
                  "Meshes: 3D table length counts swept by the cell method")
        ->capture_default_str();
    b->add_option("--vtk-mappers", ba->vtkMappers,
                  "Meshes: VTK peers to run (bunyk, projected_tetrahedra, zsweep)")
        ->capture_default_str();
    b->add_option("--vtk-script", ba->vtkScript, "Path of bench/vtk_raycast.py")->capture_default_str();
    b->callback([ba, &global] { benchRender(*ba, global); });
}

} // namespace volcl::cli
