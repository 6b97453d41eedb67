// `volcl demo`: the main job on embedded defaults (generated phantoms, checked against references).
#include "apps/cli/Commands.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/Timing.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/phantoms/Phantoms.hpp"
#include "host/tf/TransferFunction.hpp"
#include "preintegration/PreintegrationTable.hpp"
#include "render/CameraFraming.hpp"
#include "render/RenderInput.hpp"
#include "wavelet/Codec.hpp"

#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>

namespace volcl::cli {

namespace {

double maxAbsDifference(const Volume& a, const Volume& b) {
    auto x = a.values<float>();
    auto y = b.values<float>();
    double m = 0;
    for (std::size_t i = 0; i < x.size(); ++i)
        m = std::max(m, std::abs(double(x[i]) - double(y[i])));
    return m;
}

// Voxels where kernel and reference disagree although the sample is not on an ellipsoid surface.
std::size_t sheppLoganMismatches(const Volume& gpu, const Volume& ref) {
    auto x = gpu.values<float>();
    auto y = ref.values<float>();
    const Dims& d = gpu.dims();
    std::size_t bad = 0;
    for (std::size_t k = 0; k < d.z; ++k)
        for (std::size_t j = 0; j < d.y; ++j)
            for (std::size_t i = 0; i < d.x; ++i) {
                std::size_t n = gpu.index(i, j, k);
                if (std::abs(x[n] - y[n]) > 1e-6f &&
                    sheppLoganBoundaryMargin(phantomCoordinate(i, d.x), phantomCoordinate(j, d.y),
                                             phantomCoordinate(k, d.z)) > 1e-5)
                    ++bad;
            }
    return bad;
}

// Transfer function for the (band-limited) Shepp-Logan phantom, densities 0..1: a faint blue brain,
// orange small structures and ventricle walls, a translucent ivory skull. Extinction is per voxel
// (spacing 1).
constexpr const char* kPhantomTf = R"({
  "domain": [0, 1],
  "color": [[0, 0, 0, 0], [0.18, 0.15, 0.25, 0.6], [0.22, 0.15, 0.25, 0.6], [0.3, 0.95, 0.45, 0.1],
            [0.45, 0.9, 0.7, 0.3], [1, 0.85, 0.8, 0.7]],
  "extinction": [[0, 0], [0.12, 0], [0.2, 0.002], [0.24, 0.002], [0.3, 0.3], [0.36, 0.01], [0.8, 0.01],
                 [1, 0.06]]
})";

// The phantom band-limited by three passes of the binomial filter [1 2 1] / 4 along each axis (a Gaussian
// of sigma ~1.2 voxels). The generated phantom is piecewise constant, so its surfaces are voxel
// staircases: rendered directly, every sampling phase shows them as moire rings, and its gradients
// (hence shading) are zero inside and random on the steps. Smooth ramps are what a scanner delivers and
// what the renderer's trilinear sampling and pre-integration follow.
Volume bandLimited(const Volume& v) {
    const Dims d = v.dims();
    std::vector<float> a = v.toFloat(), b(a.size());
    const std::size_t stride[3] = {1, d.x, d.x * d.y};
    const std::size_t n[3] = {d.x, d.y, d.z};
    for (int pass = 0; pass < 3; ++pass)
        for (int axis = 0; axis < 3; ++axis) {
            const std::size_t s = stride[axis], len = n[axis];
            for (std::size_t k = 0; k < d.z; ++k)
                for (std::size_t j = 0; j < d.y; ++j)
                    for (std::size_t i = 0; i < d.x; ++i) {
                        const std::size_t at = v.index(i, j, k);
                        const std::size_t c = axis == 0 ? i : axis == 1 ? j : k;
                        // Clamped ends: the border value continues outward.
                        const float lo = a[c > 0 ? at - s : at], hi = a[c + 1 < len ? at + s : at];
                        b[at] = 0.25f * lo + 0.5f * a[at] + 0.25f * hi;
                    }
            std::swap(a, b);
        }
    Volume out(d, ScalarType::Float32);
    std::copy(a.begin(), a.end(), out.values<float>().begin());
    return out;
}

// Largest difference between table entries and the double reference over a deterministic sample.
double sampledTableError(const PreintegrationTable& table, const TransferFunction& tf, int samples) {
    double worst = 0;
    std::uint64_t state = 0x9e3779b97f4a7c15ull;
    auto next = [&state](int n) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        return int((state >> 33) % std::uint64_t(n));
    };
    for (int n = 0; n < samples; ++n) {
        int i = next(table.size()), j = next(table.size());
        auto ref = referenceSegment(tf, table.node(i), table.node(j), table.lengthValues[0]);
        auto got = table.entry(0, i, j);
        for (int c = 0; c < 4; ++c)
            worst = std::max(worst, std::abs(double(got[c]) - ref[c]));
    }
    return worst;
}

void writeBytes(const std::filesystem::path& path, const std::vector<std::byte>& bytes) {
    AtomicFile out(path);
    out.write(bytes);
    out.commit();
}

} // namespace

void addDemoCommand(CLI::App& app, GlobalOptions& global) {
    auto* cmd =
        app.add_subcommand("demo", "Run the pipeline on generated data (Marschner-Lobb, Shepp-Logan)");
    struct Args {
        std::string outDir = "volcl-demo";
        std::size_t mlSize = 41, phantomSize = 128;
    };
    auto a = std::make_shared<Args>();
    cmd->add_option("-o,--output-dir", a->outDir, "Directory for the demo's output files")
        ->capture_default_str();
    cmd->add_option("--ml-size", a->mlSize, "Marschner-Lobb samples per axis")
        ->capture_default_str()
        ->check(CLI::Range(std::size_t(2), std::size_t(1024)));
    cmd->add_option("--phantom-size", a->phantomSize, "Shepp-Logan samples per axis")
        ->capture_default_str()
        ->check(CLI::Range(std::size_t(2), std::size_t(1024)));
    cmd->callback([a, &global] {
        ComputeContext cc(global.device);
        if (!global.quiet)
            std::cerr << "volcl demo: device " << cc.device().name << " (" << cc.device().platform << ")\n";
        std::filesystem::create_directories(a->outDir);

        Stopwatch sw;
        Volume ml = generateMarschnerLobb(cc, {a->mlSize, a->mlSize, a->mlSize});
        double mlMs = sw.milliseconds();
        double mlErr = maxAbsDifference(ml, marschnerLobbReference(ml.dims()));
        // float sin/cos of arguments up to 6*2*pi: a few ulp of 40 in the argument, so 1e-5 absolute.
        if (!(mlErr <= 1e-5))
            throw Error("Marschner-Lobb kernel differs from the double reference by " +
                        std::to_string(mlErr));
        if (!global.quiet)
            std::cerr << "  marschner_lobb " << a->mlSize << "^3 in " << mlMs
                      << " ms (incl. first build), max |kernel - "
                      << "reference| = " << mlErr << '\n';

        sw.restart();
        Volume sl = generateSheppLogan(cc, {a->phantomSize, a->phantomSize, a->phantomSize});
        double slMs = sw.milliseconds();
        std::size_t bad = sheppLoganMismatches(sl, sheppLoganReference(sl.dims()));
        if (bad != 0)
            throw Error("Shepp-Logan kernel differs from the reference at " + std::to_string(bad) +
                        " interior voxels");
        if (!global.quiet)
            std::cerr << "  shepp_logan " << a->phantomSize << "^3 in " << slMs
                      << " ms (incl. first build), matches the reference off the ellipsoid surfaces\n";

        auto mlPath = std::filesystem::path(a->outDir) / "marschner_lobb.nrrd";
        auto slPath = std::filesystem::path(a->outDir) / "shepp_logan.nrrd";
        writeVolumeFile(ml, mlPath);
        writeVolumeFile(sl, slPath);
        for (const auto& p : {mlPath, slPath})
            printVolumeInfo(std::cout, p.string(), readVolumeFile(p), false, global.quiet);

        // Pre-integration table for the phantom's transfer function, spot-checked against the reference.
        const auto dir = std::filesystem::path(a->outDir);
        TransferFunction tf = TransferFunction::fromJson(kPhantomTf);
        {
            AtomicFile out(dir / "phantom_tf.json");
            out.write(tf.toJson());
            out.commit();
        }
        TableSpec spec;
        spec.size = 256;
        spec.step = 0.5;
        PreintegrationTable table = generatePreintegrationTable(tf, spec, {}, &cc);
        double tableErr = sampledTableError(table, tf, 2000);
        if (!(tableErr <= 1e-4))
            throw Error("pre-integration table differs from the reference by " + std::to_string(tableErr));
        table.writeExr(dir / "phantom_preint.exr");
        std::cout << "pre-integration table " << spec.size << "x" << spec.size << " (step " << spec.step
                  << ", exact) in " << table.deviceMilliseconds
                  << " ms kernel time, max error on 2000 sampled entries " << tableErr << "\n  -> "
                  << (dir / "phantom_preint.exr").string() << '\n';

        // Shaded direct volume rendering of the band-limited phantom with 2D pre-integration: seen from the
        // front, 35 degrees to the right and 25 up, the front third cut away to show the inside.
        const Volume smooth = bandLimited(sl);
        Scene scene;
        scene.width = scene.height = 384;
        scene.mode = RenderMode::Dvr;
        scene.step = 0.25;
        scene.preintegration = Preintegration::Table2d;
        const WorldBox box = volumeBox(smooth);
        scene.camera = frameBox(box, orbitDirection(35, 25), Projection::Orthographic, 30.0, 1.0);
        scene.camera->height *= 0.75; // the head fills about 0.8 of the box: frame it, not the box's sphere
        scene.effects.shading = scene.effects.shadingGiven = true;
        scene.effects.ambient = 0.3;
        scene.effects.diffuse = 0.6;
        scene.effects.specular =
            0.0; // a head light's highlight sits where every layer faces the eye: it saturates
        scene.effects.shininess = 24;
        scene.lights.push_back({LightKind::Head, {0, 0, -1}, {1, 1, 1}, 1.0});
        const double cutY = box.origin[1] + 0.62 * box.extent[1];
        scene.effects.clipPlanes.push_back({{0, -1, 0}, cutY}); // keeps y <= cutY
        scene.validate();
        const std::unique_ptr<VolumeRenderer> renderer =
            RenderInput::borrow(smooth).makeRenderer(cc, tf, scene);
        ImageBuffer image = renderer->render();
        writeImage(compositeOverSrgb(image, {0.0, 0.0, 0.0, 1.0}), dir / "phantom.png");
        std::cout
            << "rendered " << scene.width << "x" << scene.height
            << " DVR of the band-limited phantom (shaded, head light, front cut away, 2D pre-integration, "
               "step "
            << scene.step << ") in " << renderer->lastKernelMilliseconds() << " ms kernel time\n  -> "
            << (dir / "phantom.png").string() << '\n';

        // Wavelet codec: lossless and --max-error round trips of the Marschner-Lobb volume.
        for (bool lossless : {true, false}) {
            CodecOptions co;
            co.rate = lossless ? RateMode::Lossless : RateMode::MaxError;
            co.target = lossless ? 0.0 : 1e-3;
            EncodeReport report;
            std::vector<std::byte> vcz = encodeVolume(cc, ml, co, &report);
            Volume back = decodeVolume(cc, vcz, {}, "demo");
            double err = maxAbsError(ml, back);
            if (lossless ? err != 0.0 : !(err <= co.target))
                throw Error("codec round trip error " + std::to_string(err) + " breaks its bound");
            auto path = dir / (lossless ? "marschner_lobb_lossless.vcz" : "marschner_lobb_1e-3.vcz");
            writeBytes(path, vcz);
            std::cout << "codec " << (lossless ? "lossless" : "max-error 1e-3") << ": " << report.bitsPerVoxel
                      << " bits/voxel (ratio " << 32.0 / report.bitsPerVoxel << ":1), max error " << err
                      << "\n  -> " << path.string() << '\n';
        }
    });
}

} // namespace volcl::cli
