// `volcl bench render --scatter-sweep`: plain, single-scattering and path-traced frames against a converged
// path-traced reference (time, cost ratio, RMSE against samples).
#include "apps/bench/ScatterBench.hpp"

#include "core/Error.hpp"
#include "core/runtime/Timing.hpp"
#include "host/image/ImageIo.hpp"
#include "render/Reference.hpp"
#include "render/VolumeRenderer.hpp"

#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <vector>

namespace volcl::cli {
namespace {

/// Median kernel milliseconds of `runs` frames after a warm-up (kernel build excluded); `last` receives the
/// last frame.
double medianFrameMs(VolumeRenderer& r, int runs, ImageBuffer* last = nullptr) {
    r.render();
    std::vector<double> ms;
    for (int i = 0; i < std::max(runs, 1); ++i) {
        ImageBuffer img = r.render();
        ms.push_back(r.lastKernelMilliseconds());
        if (last) *last = std::move(img);
    }
    return median(ms);
}

/// The scattering medium the benchmark renders: the scene's, or a cloud-like default.
Scene scatteringScene(const Scene& scene) {
    Scene s = scene;
    s.preintegration = Preintegration::None;
    s.effects.shading = false;
    s.effects.isosurfaces.clear();
    s.effects.clipPlanes.clear();
    if (!scene.effects.scattering) {
        s.effects.scattering = true;
        s.effects.albedo = 0.95;
        s.effects.phaseG = 0.6;
        s.effects.emission = false;
        s.effects.environment = {0.15, 0.2, 0.3};
    }
    bool lit = false;
    for (const auto& l : s.lights)
        lit = lit || l.intensity > 0.0;
    if (!lit) s.lights = {Light{LightKind::Directional, {0.5, 0.7, -0.5}, {1.0, 0.95, 0.9}, 2.0}};
    return s;
}

} // namespace

void benchScattering(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                     const Scene& scene, const ScatterBenchOptions& o) {
    if (o.referenceSamples < 1 || o.maxSamples < 1)
        throw UsageError("bench render: sample counts must be >= 1");
    const Scene medium = scatteringScene(scene);
    Scene plain = medium;
    plain.effects = {};
    plain.lights.clear();
    const std::unique_ptr<VolumeRenderer> r = input.makeRenderer(cc, tf, plain);
    ImageBuffer plainImg;
    const double plainMs = medianFrameMs(*r, o.runs, &plainImg);

    Scene ref = medium;
    ref.effects.scatteringOrder = ScatteringOrder::Multiple;
    ref.effects.samples = o.referenceSamples;
    ref.effects.seed = 0x5eedU;
    r->setScene(ref);
    if (!r->plan().pathTracing)
        throw UsageError("bench render: the scene's scattering was dropped:\n" + r->plan().explain());
    const ImageBuffer reference = r->render();
    const double refMs = r->lastKernelMilliseconds();

    struct Row {
        std::string variant;
        int samples;
        double ms, rmse;
    };
    std::vector<Row> rows;
    rows.push_back({"plain (no scattering)", 0, plainMs, imageRmse(plainImg, reference)});

    Scene single = medium;
    single.effects.scatteringOrder = ScatteringOrder::Single;
    single.effects.shadows = true;
    single.effects.shadowStep = 0.0; // the render step
    r->setScene(single);
    ImageBuffer singleImg;
    const double singleMs = medianFrameMs(*r, o.runs, &singleImg);
    rows.push_back({"single scattering + shadow rays", 0, singleMs, imageRmse(singleImg, reference)});
    // The fast approximation of multiple scattering: single scattering with octaves.
    ImageBuffer octaveImg;
    for (int octaves : {2, 4, 6}) {
        Scene oct = single;
        oct.effects.octaves = octaves;
        r->setScene(oct);
        ImageBuffer img;
        const double ms = medianFrameMs(*r, o.runs, &img);
        rows.push_back(
            {"single + " + std::to_string(octaves) + " octaves (approx.)", 0, ms, imageRmse(img, reference)});
        if (octaves == 4) octaveImg = img;
    }

    Scene multi = ref;
    multi.effects.seed = 1;
    std::vector<std::pair<int, ImageBuffer>> images;
    for (int n = 1; n <= o.maxSamples; n *= 2) {
        multi.effects.samples = n;
        r->setScene(multi);
        ImageBuffer img;
        const double ms = medianFrameMs(*r, n >= 64 ? 1 : o.runs, &img);
        rows.push_back({"multiple (path tracer)", n, ms, imageRmse(img, reference)});
        if (n == 1 || n == 16 || n == o.maxSamples || 2 * n > o.maxSamples) images.emplace_back(n, img);
    }

    std::cout << "scattering, " << scene.width << "x" << scene.height << ", step " << scene.step
              << ", albedo " << medium.effects.albedo << ", g " << medium.effects.phaseG
              << (medium.effects.emission ? "" : ", no emission") << "; reference: path tracer, "
              << o.referenceSamples << " samples/pixel (" << std::fixed << std::setprecision(0) << refMs
              << " ms); error = RMSE of RGBA against it\n";
    std::cout << "  " << std::left << std::setw(34) << "variant" << std::right << std::setw(8) << "spp"
              << std::setw(12) << "ms/frame" << std::setw(10) << "x plain" << std::setw(12) << "rmse" << '\n';
    for (const Row& row : rows)
        std::cout << "  " << std::left << std::setw(34) << row.variant << std::right << std::setw(8)
                  << (row.samples ? std::to_string(row.samples) : "-") << std::setw(12)
                  << std::setprecision(2) << row.ms << std::setw(10) << std::setprecision(1)
                  << row.ms / plainMs << std::setw(12) << std::setprecision(5) << row.rmse << '\n';
    if (!o.csv.empty()) {
        std::ofstream csv(o.csv);
        csv << "variant,samples,ms,cost,rmse,reference_samples\n";
        for (const Row& row : rows)
            csv << '"' << row.variant << "\"," << row.samples << ',' << row.ms << ',' << row.ms / plainMs
                << ',' << row.rmse << ',' << o.referenceSamples << '\n';
        if (!csv) throw IoError(o.csv.string() + ": cannot write the scattering CSV");
    }
    if (!o.imageDir.empty()) {
        std::filesystem::create_directories(o.imageDir);
        auto save = [&](const ImageBuffer& img, const std::string& name) {
            writeImage(img, o.imageDir / (name + ".exr"));
            writeImage(compositeOverSrgb(img, scene.background), o.imageDir / (name + ".png"));
        };
        save(reference, "reference");
        save(plainImg, "plain");
        save(singleImg, "single");
        save(octaveImg, "octaves4");
        for (const auto& [n, img] : images)
            save(img, "multiple_" + std::to_string(n) + "spp");
    }
}

} // namespace volcl::cli
