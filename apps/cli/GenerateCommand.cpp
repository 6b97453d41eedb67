// `volcl generate`: synthetic volumes for rendering; `generate cloud` makes cloud density from seeded noise,
// into a .vcz brick row by brick row when the output is one (volumes larger than memory).
#include "apps/cli/CliParsing.hpp"
#include "apps/cli/Commands.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/runtime/PeakMemory.hpp"
#include "core/runtime/Timing.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/phantoms/Cloud.hpp"
#include "wavelet/stream/StreamEncoder.hpp"

#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

namespace volcl::cli {

void addGenerateCommand(CLI::App& app, GlobalOptions& global) {
    auto* gen = app.add_subcommand("generate", "Generate synthetic volumes (clouds from 3D noise)");
    gen->require_subcommand(1);
    auto* cmd = gen->add_subcommand(
        "cloud",
        "Cloud density (uint8) from fBm Perlin noise eroded by Worley noise, z up; seeded, reproducible");
    struct Args {
        std::string output, size, preset;
        std::uint32_t seed = 1;
        std::optional<int> octaves;
        std::optional<double> frequency, coverage, erosion;
    };
    auto a = std::make_shared<Args>();
    cmd->add_option(
           "-o,--output", a->output,
           "Output volume (format from the extension: .nrrd, .nii.gz, .vti, .vdb, .raw; .vcz is encoded "
           "losslessly while it is generated, one brick row at a time, never holding the whole volume)")
        ->required();
    cmd->add_option("--size", a->size, "X,Y,Z voxels (default 128,128,32; the preset's size with --preset)");
    cmd->add_option("--seed", a->seed, "Noise seed: the same seed gives the same bytes")
        ->capture_default_str();
    cmd->add_option("--preset", a->preset, "roettger: Roettger's 513x513x65 cloud layer")
        ->check(CLI::IsMember({"roettger"}));
    cmd->add_option("--octaves", a->octaves, "Perlin fBm octaves, 1..12 (default 5)");
    cmd->add_option("--frequency", a->frequency,
                    "Base noise cells across the largest axis (default 4; preset 6)");
    cmd->add_option("--coverage", a->coverage,
                    "Fraction of the noise range that becomes cloud, (0, 1] (default 0.45)");
    cmd->add_option("--erosion", a->erosion, "Weight of the Worley erosion, [0, 1] (default 0.35)");
    cmd->callback([a, &global] {
        CloudParams p = a->preset == "roettger" ? roettgerCloudPreset() : CloudParams{};
        if (!a->size.empty()) p.dims = parseDims(a->size, "--size");
        p.seed = a->seed;
        if (a->octaves) p.octaves = *a->octaves;
        if (a->frequency) p.frequency = *a->frequency;
        if (a->coverage) p.coverage = *a->coverage;
        if (a->erosion) p.erosion = *a->erosion;
        Stopwatch sw;
        if (std::filesystem::path(a->output).extension() == ".vcz") {
            // Generated and coded row by row: memory stays at one brick row whatever the size.
            VolumeSource src;
            src.dims = p.dims;
            src.type = ScalarType::UInt8;
            src.fill = [&p](Dims lo, Volume& out) { generateCloudRegion(p, lo, out); };
            ComputeContext cc(global.device);
            AtomicFile out(a->output);
            const StreamEncodeReport r =
                encodeStreaming(cc, src, CodecOptions{}, true, out.stream(), a->output);
            out.commit();
            if (!global.quiet)
                std::cerr << "cloud " << p.dims.x << "x" << p.dims.y << "x" << p.dims.z << " seed " << p.seed
                          << " -> " << a->output << ": " << r.bytes << " bytes, " << r.rows
                          << " brick rows of at most " << r.rowBytes << " bytes, peak RSS "
                          << peakResidentBytes() / (1024 * 1024) << " MiB for a volume of "
                          << p.dims.count() / (1024 * 1024) << " MiB decoded (" << sw.milliseconds()
                          << " ms)\n";
            return;
        }
        const Volume v = generateCloud(p);
        writeVolumeFile(v, a->output);
        if (!global.quiet)
            std::cerr << "cloud " << p.dims.x << "x" << p.dims.y << "x" << p.dims.z << " seed " << p.seed
                      << " -> " << a->output << " (" << sw.milliseconds() << " ms)\n";
    });
}

} // namespace volcl::cli
