// `volcl bench render --shadow-sweep`: light-volume shadows against secondary rays, interleaved medians per light kind.
#include "apps/bench/ShadowBench.hpp"

#include "apps/bench/BenchOutput.hpp"
#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "core/runtime/Timing.hpp"
#include "render/Reference.hpp"
#include "render/bricks/BrickRenderer.hpp"
#include "render/grid/GridRenderer.hpp"
#include "wavelet/Codec.hpp"

#include <algorithm>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace volcl::cli {
namespace {

/// One measured configuration: its renderer (kept for the interleaved rounds), times and error.
struct Variant {
    std::string light, method, knob;
    std::unique_ptr<VolumeRenderer> renderer;
    double buildMs = 0.0;
    std::vector<double> ms;
    ImageBuffer image;
    double rmse = -1.0;
};

/// The ratio row: each light's shadowed frame (light volume of the first cell size) over the plain frame.
void shadowedPlainRatio(const std::vector<Variant>& rows, double plainMs) {
    std::cout << "  shadowed/plain:";
    for (const Variant& v : rows)
        if (v.method == "volume" && &v == &*std::find_if(rows.begin(), rows.end(), [&](const Variant& w) {
                return w.method == "volume" && w.light == v.light;
            }))
            std::cout << " " << v.light << " (" << v.knob << ") " << std::setprecision(2)
                      << median(v.ms) / plainMs << "x, RMSE " << std::scientific << v.rmse << std::fixed
                      << ";";
    std::cout << " plain " << std::setprecision(1) << plainMs << " ms\n";
}

/// The last light-volume build of a grid or compressed-brick renderer, 0 when it has none.
double lightVolumeBuildMs(const VolumeRenderer& r) {
    if (const auto* g = dynamic_cast<const GridRenderer*>(&r)) return g->lastLightVolumeMilliseconds();
    if (const auto* b = dynamic_cast<const BrickRenderer*>(&r)) return b->lastLightVolumeMilliseconds();
    return 0.0;
}

} // namespace

void benchShadows(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                  const Scene& scene, const ShadowBenchOptions& o) {
    const Volume* grid = input.grid();
    if (!grid && !input.bricks())
        throw UsageError("bench render: --shadow-sweep measures grids and .vcz files (give a volume)");
    const std::array<double, 3> spacing = grid ? grid->spacing : input.bricks()->header().spacing;
    if (o.rounds < 1 || o.cells.empty() || o.raySteps.empty())
        throw UsageError(
            "bench render: --shadow-sweep needs rounds >= 1, light-volume cells and shadow-ray steps");
    const double voxel = std::min({spacing[0], spacing[1], spacing[2]});
    Scene plain = scene;
    plain.effects = {};
    plain.lights.clear();
    std::vector<Variant> rows;
    auto add = [&](std::string light, std::string method, std::string knob, const Scene& s) {
        Variant v{std::move(light), std::move(method), std::move(knob), nullptr, 0.0, {}, {}, -1.0};
        v.renderer = input.makeRenderer(cc, tf, s);
        v.image = v.renderer->render(); // builds tables and light volumes
        v.buildMs = lightVolumeBuildMs(*v.renderer);
        rows.push_back(std::move(v));
    };
    add("-", "plain", "-", plain);
    const Light sun{LightKind::Directional, {0.4, 0.6, -0.7}, {1, 1, 1}, 1.0};
    const Light head{LightKind::Head, {0, 0, 0}, {1, 1, 1}, 1.0};
    struct RayRow {
        std::string light, knob;
        double ms;
        double rmse;
    };
    std::vector<RayRow> rays;
    for (const auto& [name, light] :
         {std::pair{std::string("directional"), sun}, std::pair{std::string("head"), head}}) {
        Scene lit = scene;
        lit.lights = {light};
        lit.effects.shading = lit.effects.shadingGiven = true;
        lit.effects.shadows = false;
        const std::size_t first = rows.size();
        add(name, "shaded, no shadows", "-", lit);
        lit.effects.shadows = true;
        // The exact method first: its image at the first step is every row's reference.
        ImageBuffer reference;
        for (double step : o.raySteps) {
            Scene s = lit;
            s.effects.shadowMethod = ShadowMethod::Rays;
            s.effects.shadowStep = step * voxel;
            const std::unique_ptr<VolumeRenderer> r = input.makeRenderer(cc, tf, s);
            const ImageBuffer img = r->render();
            if (reference.pixels.empty()) reference = img;
            rays.push_back({name, "step " + std::to_string(step).substr(0, 4), r->lastKernelMilliseconds(),
                            imageRmse(img, reference)});
        }
        for (int cell : o.cells) {
            Scene s = lit;
            s.effects.shadowMethod = ShadowMethod::Volume;
            s.effects.lightVolumeCell = cell;
            s.effects.shadowStep = o.raySteps.front() * voxel;
            add(name, "volume", "cell " + std::to_string(cell), s);
        }
        for (std::size_t i = first; i < rows.size(); ++i)
            rows[i].rmse = imageRmse(rows[i].image, reference);
        if (first == 1) rows[0].rmse = imageRmse(rows[0].image, reference); // plain, against the directional
    }
    for (int round = 0; round < o.rounds; ++round)
        for (Variant& v : rows) {
            v.renderer->render();
            v.ms.push_back(v.renderer->lastKernelMilliseconds());
        }
    const double plainMs = median(rows[0].ms);
    std::ostringstream csv;
    csv << "light,method,knob,build_ms,ms,ratio_plain,rmse\n";
    std::cout << "shadows, " << (grid ? "grid" : "compressed bricks (" + input.bricks()->name() + ")") << ", "
              << scene.width << "x" << scene.height << ", step " << scene.step << ", medians of " << o.rounds
              << " interleaved rounds (ray frames: one each), RMSE of RGBA against "
              << "secondary rays at step " << o.raySteps.front() << " voxel, load average " << loadAverage()
              << '\n';
    std::cout << "  light        method               knob       build ms   ms/frame    /plain   RMSE\n";
    auto line = [&](const std::string& light, const std::string& method, const std::string& knob,
                    double build, double ms, double rmse) {
        std::cout << "  " << std::left << std::setw(12) << light << " " << std::setw(20) << method << " "
                  << std::setw(10) << knob << std::right << std::fixed << std::setprecision(1) << std::setw(9)
                  << build << "  " << std::setw(9) << ms << "  " << std::setprecision(2) << std::setw(7)
                  << ms / plainMs << "   " << std::scientific << std::setprecision(2) << rmse << std::fixed
                  << '\n';
        csv << light << ',' << method << ',' << knob << ',' << build << ',' << ms << ',' << ms / plainMs
            << ',' << rmse << '\n';
    };
    for (const Variant& v : rows)
        line(v.light, v.method, v.knob, v.buildMs, median(v.ms), v.rmse);
    for (const RayRow& r : rays)
        line(r.light, "rays", r.knob, 0.0, r.ms, r.rmse);
    shadowedPlainRatio(rows, plainMs);
    if (!o.csv.empty()) writeOutput(o.csv.string(), csv.str());
}

} // namespace volcl::cli
