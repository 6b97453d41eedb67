// `volcl bench render --shading-sweep`: shaded frames per gradient kind against the plain frame, the reference
// and VTK's shaded fixed-point ray caster.
#include "apps/bench/ShadingBench.hpp"

#include "apps/bench/MeshBench.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/runtime/Timing.hpp"
#include "render/VolumeRenderer.hpp"
#include "render/grid/GridRenderer.hpp"

#include <algorithm>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace volcl::cli {

void benchShading(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                  const Scene& scene, const ShadingBenchOptions& o) {
    if (o.runs < 1) throw UsageError("bench render --shading-sweep: --runs must be at least 1");
    Scene plain = scene;
    plain.effects.shading = false;
    plain.effects.shadingGiven = true;
    plain.effects.isosurfaces.clear();
    plain.lights.clear();
    Scene shaded = scene;
    shaded.effects.isosurfaces.clear();
    if (!shaded.effects.shading || shaded.lights.empty()) {
        shaded.effects.shading = true;
        shaded.effects.shadingGiven = true;
        shaded.lights = {Light{LightKind::Head, {0, 0, -1}, {1, 1, 1}, 1.0}};
    }
    Scene iso = plain;
    iso.effects.isosurfaces = {{0.5 * (tf.domain[0] + tf.domain[1]), {1, 1, 1, 0.5}}};

    struct Variant {
        std::string name;
        Scene scene;
        std::unique_ptr<VolumeRenderer> renderer;
        std::vector<double> ms;
        ImageBuffer image;
        bool timed = true;
    };
    std::vector<Variant> vs;
    vs.push_back({"plain", plain, nullptr, {}, {}});
    // Central differences come first: the other kinds' RMSE is taken against its image, rendered once when the
    // list does not time it.
    std::vector<GradientKind> kinds = {GradientKind::Central};
    for (GradientKind g : o.gradients)
        if (g != GradientKind::Central) kinds.push_back(g);
    for (GradientKind g : kinds) {
        Scene s = shaded;
        s.effects.gradient = g;
        vs.push_back({"shaded (gradient " + std::string(gradientKindName(g)) + ")", s, nullptr, {}, {}});
    }
    vs[1].timed =
        std::find(o.gradients.begin(), o.gradients.end(), GradientKind::Central) != o.gradients.end();
    vs.push_back({"iso layer mixed into dvr", iso, nullptr, {}, {}});
    double cacheBuildMs = -1.0;
    for (Variant& v : vs) {
        v.renderer = input.makeRenderer(cc, tf, v.scene);
        v.image = v.renderer->render(); // warm-up: kernel build, tables, the gradient cache
        if (const auto* g = dynamic_cast<const GridRenderer*>(v.renderer.get());
            g && g->gradientCacheBuildMs() >= 0)
            cacheBuildMs = g->gradientCacheBuildMs();
    }
    // VTK runs in the same rounds (one process per frame kind and round, its own median of its frames), so
    // a load change moves both sides alike.
    std::vector<double> vtkPlainMs, vtkShadedMs;
    ImageBuffer vtkPlainImg, vtkShadedImg;
    for (int round = 0; round < o.runs; ++round) {
        for (Variant& v : vs) {
            if (!v.timed) continue;
            v.renderer->render();
            v.ms.push_back(v.renderer->lastKernelMilliseconds());
        }
        if (o.vtk) {
            auto [pm, pi] = o.vtk(plain);
            auto [sm, si] = o.vtk(shaded);
            vtkPlainMs.push_back(pm);
            vtkShadedMs.push_back(sm);
            vtkPlainImg = std::move(pi);
            vtkShadedImg = std::move(si);
        }
    }
    Stopwatch sw;
    const ReferenceOptions ro{.step = o.referenceStep};
    Scene shadedRef = shaded;
    shadedRef.effects.gradient = GradientKind::Central;
    const ImageBuffer refPlain = input.renderReference(tf, plain, ro);
    const ImageBuffer refShaded = input.renderReference(tf, shadedRef, ro);
    const ImageBuffer refIso = input.renderReference(tf, iso, ro);
    std::cerr << "references (double, step " << o.referenceStep << "): " << std::fixed << std::setprecision(1)
              << sw.milliseconds() / 1000.0 << " s\n";
    const double plainMs = median(vs[0].ms);
    const ImageBuffer& central = vs[1].image;
    std::cout << "shading, " << scene.width << "x" << scene.height << ", step " << scene.step
              << ", median of " << o.runs << " interleaved rounds (kernel ms), load average " << loadAverage()
              << '\n';
    if (cacheBuildMs >= 0)
        std::cout << "  gradient cache: built in " << std::fixed << std::setprecision(2) << cacheBuildMs
                  << " ms once per volume, 4 bytes per voxel\n";
    std::cout
        << "  variant                              ms/frame   /plain   RMSE ref    RMSE vs central  kernel\n";
    std::ostringstream csv;
    csv << "variant,ms_per_frame,ratio_to_plain,rmse_reference,rmse_vs_central\n";
    for (std::size_t i = 0; i < vs.size(); ++i) {
        const Variant& v = vs[i];
        const bool lit = i >= 1 && i <= kinds.size();
        const ImageBuffer& ref = i == 0 ? refPlain : lit ? refShaded : refIso;
        if (!v.timed) continue;
        const double ms = median(v.ms), e = rmseRgb(v.image, ref);
        const double ec = lit ? rmseRgb(v.image, central) : 0.0;
        std::cout << "  " << std::left << std::setw(36) << v.name << std::right << std::fixed
                  << std::setprecision(2) << std::setw(9) << ms << std::setw(9) << std::setprecision(3)
                  << ms / plainMs << "   " << std::scientific << std::setprecision(3) << e << "   "
                  << (lit ? ec : 0.0) << std::fixed << "      " << v.renderer->plan().defines.toOptions()
                  << '\n';
        csv << v.name << ',' << ms << ',' << ms / plainMs << ',' << e << ',' << ec << '\n';
    }
    if (o.vtk) {
        const double vtkPlain = median(vtkPlainMs), vtkShaded = median(vtkShadedMs);
        std::size_t cached = 1; // the default gradient's row, when it was timed
        for (std::size_t i = 1; i <= kinds.size(); ++i)
            if (kinds[i - 1] == SceneEffects{}.gradient) cached = i;
        const double shadedMs = median(vs[cached].ms);
        std::cout << "  VTK vtkFixedPointVolumeRayCastMapper (in the same rounds: median of its per-round "
                     "medians):\n"
                  << std::fixed << std::setprecision(2) << "    plain  " << vtkPlain << " ms, RMSE "
                  << std::scientific << std::setprecision(3) << rmseRgb(vtkPlainImg, refPlain) << std::fixed
                  << "\n    shaded " << std::setprecision(2) << vtkShaded << " ms (" << std::setprecision(3)
                  << vtkShaded / vtkPlain << "x its plain), RMSE " << std::scientific
                  << rmseRgb(vtkShadedImg, refShaded) << std::fixed << '\n'
                  << "    volcl " << vs[cached].name << " / VTK shaded: " << std::setprecision(3)
                  << shadedMs / vtkShaded << '\n';
        csv << "vtk plain," << vtkPlain << ',' << vtkPlain / plainMs << ',' << rmseRgb(vtkPlainImg, refPlain)
            << ",0\n";
        csv << "vtk shaded," << vtkShaded << ',' << vtkShaded / plainMs << ','
            << rmseRgb(vtkShadedImg, refShaded) << ",0\n";
    }
    if (!o.csv.empty()) {
        AtomicFile out(o.csv);
        out.write("# load average " + loadAverage() + "\n" + csv.str());
        out.commit();
    }
}

} // namespace volcl::cli
