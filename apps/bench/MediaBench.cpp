// `volcl bench render --tables` / `--fog`: table paths vs per-sample paths, fog vs the plain frame.
#include "apps/bench/MediaBench.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/runtime/Timing.hpp"
#include "render/Reference.hpp"

#include <algorithm>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

namespace volcl::cli {
namespace {

struct Variant {
    std::string name;
    Scene scene;
    std::unique_ptr<VolumeRenderer> renderer;
    std::vector<double> ms;
    double rmse = 0.0, tableMs = 0.0;
};

/// Interleaved timing: one warm-up frame each, then `runs` rounds over all variants.
void timeInterleaved(std::vector<Variant>& vs, int runs) {
    for (auto& v : vs)
        v.renderer->render();
    for (int i = 0; i < runs; ++i)
        for (auto& v : vs) {
            v.renderer->render();
            v.ms.push_back(v.renderer->lastKernelMilliseconds());
        }
}

void writeCsv(const std::filesystem::path& csv, const std::string& text) {
    if (csv.empty()) return;
    AtomicFile out(csv);
    out.write(text);
    out.commit();
}

Light defaultLight() {
    return {LightKind::Directional, {0.4, 0.6, -0.7}, {1, 1, 1}, 1.0};
}

/// Prints and writes (CSV) each variant's median time, its ratio to the first variant's, its RMSE against the
/// double reference of its TF (`tfs[i]`) at `referenceStep`, and its defines.
void reportAgainstFirst(const RenderInput& input, const std::vector<const TransferFunction*>& tfs,
                        std::vector<Variant>& vs, double referenceStep, const std::filesystem::path& csv) {
    const double firstMs = median(vs[0].ms);
    std::ostringstream rows;
    rows << "variant,ms_per_frame,ratio_to_plain,rmse_rgba,defines\n"; // the first row is the plain peer
    for (std::size_t i = 0; i < vs.size(); ++i) {
        Variant& v = vs[i];
        const ImageBuffer ref = input.renderReference(*tfs[i], v.scene, {.step = referenceStep});
        v.rmse = imageRmse(v.renderer->render(), ref);
        const double ms = median(v.ms);
        std::cout << "  " << std::left << std::setw(42) << v.name << std::right << std::fixed << std::setw(9)
                  << std::setprecision(2) << ms << "  " << std::setprecision(3) << ms / firstMs << "  "
                  << std::scientific << v.rmse << std::fixed << "  ["
                  << v.renderer->plan().defines.toOptions() << "]\n";
        rows << '"' << v.name << "\"," << ms << ',' << ms / firstMs << ',' << v.rmse << ",\""
             << v.renderer->plan().defines.toOptions() << "\"\n";
    }
    writeCsv(csv, rows.str());
}

} // namespace

void benchTables(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf, const Scene& scene,
                 const std::vector<double>& steps, double referenceStep, int runs,
                 const std::filesystem::path& csv) {
    Scene lit = scene;
    lit.mode = RenderMode::Dvr;
    lit.effects.shading = true;
    lit.effects.shadingGiven = true;
    if (lit.lights.empty()) lit.lights = {defaultLight()};
    lit.effects.isosurfaces.clear();
    std::ostringstream rows;
    rows << "kind,step,variant,ms_per_frame,table_ms,rmse_rgba\n";
    std::cout << "tables vs per-sample paths, median of " << runs
              << " interleaved frames, RMSE vs the double "
              << "reference (step " << referenceStep << ")\n";
    std::cout
        << "  kind     step  variant                                   ms/frame   table ms   RMSE rgba\n";
    const ImageBuffer litRef = input.renderReference(tf, lit, {.step = referenceStep});
    for (double step : steps) {
        std::vector<Variant> vs;
        auto add = [&](std::string name, Scene s) {
            s.step = step;
            Variant v{std::move(name), s, nullptr, {}, 0.0, 0.0};
            v.renderer = input.makeRenderer(cc, tf, s);
            v.tableMs = v.renderer->lastTableMilliseconds();
            vs.push_back(std::move(v));
        };
        Scene point = lit;
        point.preintegration = Preintegration::None;
        add("per sample (point sampled, lit per sample)", point);
        Scene mid = lit;
        mid.preintegration = Preintegration::Table2d;
        add("2D pre-integration, lit at segment midpoint", mid);
        Scene table = mid;
        table.effects.shadingPreintegrated = true;
        add("2D pre-integration, pre-integrated lighting", table);
        timeInterleaved(vs, runs);
        for (auto& v : vs) {
            v.rmse = imageRmse(v.renderer->render(), litRef);
            std::cout << "  shaded  " << std::setw(5) << std::setprecision(3) << std::fixed << step << "  "
                      << std::left << std::setw(42) << v.name << std::right << std::setw(9)
                      << std::setprecision(2) << median(v.ms) << "  " << std::setw(9) << v.tableMs << "  "
                      << std::scientific << std::setprecision(3) << v.rmse << std::fixed << '\n';
            rows << "shaded," << step << ",\"" << v.name << "\"," << median(v.ms) << ',' << v.tableMs << ','
                 << v.rmse << '\n';
        }
    }
    // Iso-surfaces: exact roots per cell vs the iso-surface table.
    Scene iso = scene;
    iso.mode = RenderMode::Iso;
    iso.preintegration = Preintegration::None;
    if (iso.effects.isosurfaces.empty()) {
        const ValueRange r = input.valueRange();
        iso.effects.isosurfaces = {{0.5 * (r.min + r.max), {1.0, 0.9, 0.8, 1.0}}};
    }
    iso.effects.isosurfaces.resize(1);
    iso.effects.shading = true;
    iso.effects.shadingGiven = true;
    if (iso.lights.empty()) iso.lights = {defaultLight()};
    const ImageBuffer isoRef = input.renderReference(tf, iso, {.step = referenceStep});
    for (double step : steps) {
        std::vector<Variant> vs;
        for (bool table : {false, true}) {
            Scene s = iso;
            s.step = step;
            s.effects.isoTable = table;
            Variant v{table ? "iso-surface table" : "exact roots per cell", s, nullptr, {}, 0.0, 0.0};
            v.renderer = input.makeRenderer(cc, tf, s);
            v.tableMs = v.renderer->lastTableMilliseconds();
            vs.push_back(std::move(v));
        }
        timeInterleaved(vs, runs);
        for (auto& v : vs) {
            const ImageBuffer img = v.renderer->render();
            // Colour and coverage only: the depth channel differs in meaning (midpoint vs root).
            ImageBuffer a(img.width, img.height, {"R", "G", "B", "A"}), b = a;
            for (std::size_t i = 0; i < std::size_t(img.width) * std::size_t(img.height); ++i)
                for (int c = 0; c < 4; ++c) {
                    a.pixels[i * 4 + std::size_t(c)] =
                        img.pixels[i * std::size_t(img.channelCount()) + std::size_t(c)];
                    b.pixels[i * 4 + std::size_t(c)] =
                        isoRef.pixels[i * std::size_t(isoRef.channelCount()) + std::size_t(c)];
                }
            v.rmse = imageRmse(a, b);
            std::cout << "  iso     " << std::setw(5) << std::setprecision(3) << std::fixed << step << "  "
                      << std::left << std::setw(42) << v.name << std::right << std::setw(9)
                      << std::setprecision(2) << median(v.ms) << "  " << std::setw(9) << v.tableMs << "  "
                      << std::scientific << std::setprecision(3) << v.rmse << std::fixed << '\n';
            rows << "iso," << step << ",\"" << v.name << "\"," << median(v.ms) << ',' << v.tableMs << ','
                 << v.rmse << '\n';
        }
    }
    writeCsv(csv, rows.str());
}

void benchFog(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf, const Scene& scene,
              double referenceStep, int runs, const std::filesystem::path& csv) {
    const WorldBox box = input.bounds();
    Scene plain = scene;
    plain.mode = RenderMode::Dvr;
    plain.effects = {};
    plain.lights.clear();
    plain.preintegration = Preintegration::None;
    plain.skipping = SkipMode::Off;
    auto fogged = [&](bool exponential) {
        FogEffect f;
        f.enabled = true;
        f.density = 0.02;
        f.color = {0.8, 0.85, 0.9};
        if (exponential) {
            f.base = box.origin[1] + 0.25 * box.extent[1];
            f.falloff = 0.15 * box.extent[1];
        } else {
            f.base = box.origin[1] + 0.5 * box.extent[1];
        }
        return f;
    };
    std::vector<Variant> vs;
    auto add = [&](std::string name, Scene s) {
        Variant v{std::move(name), s, nullptr, {}, 0.0, 0.0};
        v.renderer = input.makeRenderer(cc, tf, s);
        vs.push_back(std::move(v));
    };
    add("plain (no effects, no skipping)", plain);
    Scene c = plain;
    c.effects.fog = fogged(false);
    add("fog, constant layer (falloff 0)", c);
    Scene e = plain;
    e.effects.fog = fogged(true);
    add("fog, exponential layer", e);
    Scene s = scene;
    s.effects.fog = fogged(true);
    add("scene's own settings + exponential fog", s);
    Scene p = e;
    p.preintegration = Preintegration::Table2d;
    add("exponential fog, 2D pre-integration", p);
    timeInterleaved(vs, runs);
    std::cout << "fog cost, " << scene.width << "x" << scene.height << ", step " << scene.step
              << ", median of " << runs
              << " interleaved frames; RMSE vs the double reference with the same fog (step " << referenceStep
              << ")\n";
    reportAgainstFirst(input, std::vector<const TransferFunction*>(vs.size(), &tf), vs, referenceStep, csv);
}

void benchGradientTf(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                     const std::optional<TransferFunction>& peer, const Scene& scene,
                     const std::vector<double>& steps, double referenceStep, int runs,
                     const std::filesystem::path& csv) {
    if (!tf.usesGradient())
        throw UsageError("bench render --gradient-tf: the TF (--tf) has no gradient_opacity or widgets");
    if (peer && peer->usesGradient())
        throw UsageError("bench render --gradient-tf-peer: the peer must be a 1D TF (no gradient terms)");
    TransferFunction valueAxis = peer ? *peer : tf;
    valueAxis.gradientOpacity.clear();
    valueAxis.widgets.clear();
    Scene plain = scene;
    plain.preintegration = Preintegration::None;
    plain.skipping = SkipMode::Off;
    std::vector<Variant> vs;
    std::vector<const TransferFunction*> tfs;
    auto add = [&](std::string name, const TransferFunction& t, const Scene& s) {
        Variant v{std::move(name), s, input.makeRenderer(cc, t, s), {}, 0.0, 0.0};
        vs.push_back(std::move(v));
        tfs.push_back(&t);
    };
    add((peer ? "1D peer TF, step " : "value axis alone, step ") + formatNumber(plain.step), valueAxis,
        plain);
    // The same 1D frame on the per-ray kernel with central differences (what a gradient TF runs on): a shaded
    // 1D frame otherwise takes the packet kernel and the gradient cache.
    Scene perRay = plain;
    perRay.effects.gradient = GradientKind::Central;
    add((peer ? "1D peer TF, central differences, step " : "value axis alone, central differences, step ") +
            formatNumber(plain.step),
        valueAxis, perRay);
    for (double st : steps) {
        Scene s = plain;
        s.step = st;
        add("gradient TF, step " + formatNumber(st), tf, s);
    }
    timeInterleaved(vs, runs);
    std::cout << "gradient transfer function cost, " << scene.width << "x" << scene.height << ", median of "
              << runs << " interleaved frames, load " << loadAverageText()
              << "; RMSE vs the double reference of the same TF (step " << referenceStep
              << "); ratio to the first row\n";
    reportAgainstFirst(input, tfs, vs, referenceStep, csv);
}

} // namespace volcl::cli
