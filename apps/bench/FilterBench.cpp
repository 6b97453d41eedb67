// `volcl bench render --filters`: reconstruction filters' time against accuracy, interleaved medians.
#include "apps/bench/FilterBench.hpp"

#include "core/AtomicFile.hpp"
#include "core/runtime/Timing.hpp"
#include "render/VolumeRenderer.hpp"
#include "render/grid/FilterAccuracy.hpp"

#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <vector>

namespace volcl::cli {
namespace {

struct FilterCase {
    ReconstructionFilter filter;
    GradientKind gradient;
    double smoothing;
    std::string name() const {
        std::ostringstream os;
        os << filterName(filter) << (gradient == GradientKind::Sobel ? "+sobel" : "");
        if (smoothing > 0.0) os << " s" << smoothing;
        return os.str();
    }
};

const std::vector<FilterCase>& filterCases() {
    static const std::vector<FilterCase> cases = {
        {ReconstructionFilter::Linear, GradientKind::Central, 0.0},
        {ReconstructionFilter::Linear, GradientKind::Sobel, 0.0},
        {ReconstructionFilter::Linear, GradientKind::Central, 1.0},
        {ReconstructionFilter::Cubic, GradientKind::Central, 0.0},
        {ReconstructionFilter::Bspline, GradientKind::Central, 0.0},
        {ReconstructionFilter::Bspline, GradientKind::Central, 0.7},
        {ReconstructionFilter::Bspline, GradientKind::Central, 1.0},
        {ReconstructionFilter::Bspline, GradientKind::Central, 1.5}};
    return cases;
}

struct Timed {
    std::vector<std::unique_ptr<VolumeRenderer>> renderers;
    std::vector<double> setupMs, frameMs;
};

/// One renderer per filter case (setup timed: the spline's prefilter and upload), then `runs` rounds of
/// one frame each, interleaved so load changes hit every case alike.
Timed timeCases(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf, const Scene& base,
                int runs) {
    Timed t;
    for (const auto& fc : filterCases()) {
        Scene s = base;
        s.filter = fc.filter;
        s.effects.gradient = fc.gradient;
        s.smoothing = fc.smoothing;
        Stopwatch sw;
        t.renderers.push_back(input.makeRenderer(cc, tf, s));
        t.setupMs.push_back(sw.milliseconds());
        t.renderers.back()->render(); // warm-up: kernel build
    }
    std::vector<std::vector<double>> ms(t.renderers.size());
    for (int r = 0; r < runs; ++r)
        for (std::size_t i = 0; i < t.renderers.size(); ++i) {
            t.renderers[i]->render();
            ms[i].push_back(t.renderers[i]->lastKernelMilliseconds());
        }
    for (auto& m : ms)
        t.frameMs.push_back(median(m));
    return t;
}

} // namespace

void benchFilters(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                  const Scene& scene, int runs, const std::filesystem::path& csvPath) {
    std::ostringstream csv;
    csv << "dataset,filter,setup_ms,ms_per_frame,ratio_to_linear,normal_error_deg,depth_error,roughness\n";
    std::cout << std::fixed;

    // 1. Accuracy against an analytic surface: an 8-bit sphere with one level per voxel.
    const Vec3 centre{31.4, 32.1, 31.7};
    const double radius = 22.0, slope = 1.0;
    const RenderInput sphere = RenderInput::fromVolume(quantisedSphere({64, 64, 64}, centre, radius, slope));
    const Scene ss = sphereNormalScene(centre, radius, 256);
    TransferFunction sphereTf;
    sphereTf.domain = {0.0, 255.0};
    sphereTf.color = {{0.0, {1, 1, 1}}};
    sphereTf.extinction = {{0.0, 0.0}};
    const Timed st = timeCases(cc, sphere, sphereTf, ss, runs);
    std::cout << "filters on an 8-bit sphere (64^3, 1 level/voxel), iso 128.5, 256x256, step 0.25, median of "
              << runs << " interleaved frames\n"
              << "  filter            setup ms   ms/frame  x linear   normal err deg   depth err\n";
    for (std::size_t i = 0; i < st.renderers.size(); ++i) {
        const ImageBuffer img = st.renderers[i]->render();
        const double nErr = meanNormalErrorDeg(img, ss, centre);
        const double dErr = meanDepthError(img, ss, centre, radius - 0.5 / slope);
        const double ratio = st.frameMs[i] / st.frameMs[0];
        const std::string name = filterCases()[i].name();
        std::cout << "  " << std::left << std::setw(16) << name << std::right << std::setprecision(1)
                  << std::setw(10) << st.setupMs[i] << std::setprecision(2) << std::setw(11) << st.frameMs[i]
                  << std::setw(10) << ratio << std::setw(17) << nErr << std::setprecision(4) << std::setw(12)
                  << dErr << '\n';
        csv << "sphere," << name << ',' << st.setupMs[i] << ',' << st.frameMs[i] << ',' << ratio << ','
            << nErr << ',' << dErr << ",\n";
    }

    // 2. The scene's own data: time and the terrace measure against linear.
    const Timed t = timeCases(cc, input, tf, scene, runs);
    std::vector<double> rough;
    for (auto& r : t.renderers)
        rough.push_back(shadingRoughness(r->render()));
    std::cout << "filters on the scene (" << input.summary() << ", " << renderModeName(scene.mode) << ", "
              << scene.width << "x" << scene.height << ", step " << scene.step << ")\n"
              << "  filter            setup ms   ms/frame  x linear   roughness  x linear\n";
    for (std::size_t i = 0; i < t.renderers.size(); ++i) {
        const double ratio = t.frameMs[i] / t.frameMs[0];
        const double rr = rough[0] > 0.0 ? rough[i] / rough[0] : 0.0;
        const std::string name = filterCases()[i].name();
        std::cout << "  " << std::left << std::setw(16) << name << std::right << std::setprecision(1)
                  << std::setw(10) << t.setupMs[i] << std::setprecision(2) << std::setw(11) << t.frameMs[i]
                  << std::setw(10) << ratio << std::setprecision(4) << std::setw(12) << rough[i]
                  << std::setprecision(3) << std::setw(10) << rr << '\n';
        csv << "scene," << name << ',' << t.setupMs[i] << ',' << t.frameMs[i] << ',' << ratio << ",,,"
            << rough[i] << '\n';
    }
    if (!csvPath.empty()) {
        AtomicFile out(csvPath);
        out.write(csv.str());
        out.commit();
    }
}

} // namespace volcl::cli
