// `volcl encode`, `volcl decode`, `volcl compare` and `volcl bench codec` (ours against zfp, zstd and xz).
#include "core/Error.hpp"
#include "apps/cli/CliParsing.hpp"
#include "apps/cli/Commands.hpp"
#include "core/AtomicFile.hpp"
#include "core/Format.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/Series.hpp"
#include "host/io/VolumeIo.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/Timing.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/LodStatistics.hpp"

#include <nlohmann/json.hpp>
#include <zfp.h>
#include <zlib.h>
#include <zstd.h>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

namespace volcl::cli {

namespace {

namespace fs = std::filesystem;

bool isVcz(const fs::path& p) {
    return p.extension() == ".vcz";
}

// A volume file or a .vcz (decoded whole).

// Stage times of one encode or decode, so speed claims can name their bottleneck.
void printProfile(const char* what, const CodecProfile& p, std::size_t searchTrials) {
    const double staged =
        p.gather + p.upload + p.transform + p.download + p.entropy + p.reconstruct + p.assemble + p.predict;
    std::cerr << "    " << what << " ms: total " << formatFixed(p.total, 1) << " = gather " << formatFixed(p.gather, 1)
              << " upload " << formatFixed(p.upload, 1) << " transform " << formatFixed(p.transform, 1) << " download "
              << formatFixed(p.download, 1) << " entropy " << formatFixed(p.entropy, 1)
              << " reconstruct " << formatFixed(p.reconstruct, 1) << " assemble " << formatFixed(p.assemble, 1) << " predict "
              << formatFixed(p.predict, 1) << " other "
              << formatFixed(p.total - staged, 1);
    if (p.trials > 0) std::cerr << " (" << p.trials << " quantisation rounds)";
    if (searchTrials > 0) std::cerr << " [target search: " << searchTrials << " rounds, not timed]";
    std::cerr << '\n';
}

nlohmann::json jsonNumber(double v) {
    if (std::isfinite(v)) return v;
    return std::isnan(v) ? nlohmann::json("nan") : nlohmann::json(v > 0 ? "inf" : "-inf");
}

// ------------------------------------------------------------------------------ encode / decode / compare

struct EncodeArgs {
    std::vector<std::string> in; ///< one file, several files, quoted globs or a .pvd: the frames in order
    std::string out, wavelet, entropy = "dense", brick = "64", motion = "block";
    std::size_t gop = 10, bFrames = 0;
    bool lossless = false, profile = false, lodStats = true, globalShift = true;
    double maxError = 0, psnr = 0, bpv = 0, step = 0;
    int levels = 4;
    unsigned threads = 2;
    RawReadFlags raw;
};

CodecOptions toOptions(const EncodeArgs& a, const CLI::App& cmd) {
    CodecOptions o;
    int chosen = 0;
    if (cmd.count("--lossless")) ++chosen;
    if (cmd.count("--max-error")) {
        ++chosen;
        o.rate = RateMode::MaxError;
        o.target = a.maxError;
    }
    if (cmd.count("--psnr")) {
        ++chosen;
        o.rate = RateMode::Psnr;
        o.target = a.psnr;
    }
    if (cmd.count("--bpv")) {
        ++chosen;
        o.rate = RateMode::Bpv;
        o.target = a.bpv;
    }
    if (chosen > 1) throw UsageError("choose one of --lossless, --max-error, --psnr, --bpv");
    if (cmd.count("--step")) {
        if (o.rate == RateMode::Lossless)
            throw UsageError("--step needs a lossy mode (--max-error, --psnr or --bpv)");
        o.step = a.step;
    }
    if (!a.wavelet.empty()) o.wavelet = parseWavelet(a.wavelet);
    o.entropy = parseEntropy(a.entropy);
    if (a.brick.find_first_of(",xX") != std::string::npos) {
        o.brick = parseDims(a.brick, "--brick");
    } else {
        std::size_t b = 0;
        try {
            b = std::stoul(a.brick);
        } catch (const std::exception&) {
            throw UsageError("--brick '" + a.brick + "' must be a number or X,Y,Z");
        }
        o.brick = {b, b, b};
    }
    o.levels = a.levels;
    o.threads = std::max(1u, a.threads);
    if (a.motion == "block")
        o.motion = MotionMode::Block;
    else if (a.motion == "none")
        o.motion = MotionMode::None;
    else
        throw UsageError("--motion must be block or none");
    if (a.gop == 0) throw UsageError("--gop must be at least 1");
    o.gop = a.gop;
    o.bFrames = a.bFrames;
    o.globalShift = a.globalShift;
    return o;
}

void addEncode(CLI::App& app, GlobalOptions& global) {
    auto* cmd = app.add_subcommand("encode", "Compress a volume into a .vcz file (wavelet lifting codec)");
    auto a = std::make_shared<EncodeArgs>();
    cmd->add_option("input", a->in,
                    "Input volume(s): one file (a 4D file keeps its frames), several files in frame order, a "
                    "quoted glob ('run_*.vti', natural order) or a ParaView .pvd")
        ->required();
    cmd->add_option("-o,--output", a->out, "Output .vcz file")->required();
    cmd->add_flag("--lossless", a->lossless, "Bit-exact (default)");
    cmd->add_option("--max-error", a->maxError, "Lossy: every voxel within E of the input (guaranteed)");
    cmd->add_option("--psnr", a->psnr,
                    "Lossy: PSNR in dB over the input's value range (met within " +
                        formatNumber(kPsnrToleranceDb) + " dB)");
    cmd->add_option("--bpv", a->bpv, "Lossy: at most R bits per voxel, file overhead included");
    cmd->add_option("--step", a->step, "Lossy: fixed base quantiser step instead of a search for the target");
    cmd->add_option("--wavelet", a->wavelet,
                    "cdf53 | cdf97 | haar | cdf26 (default cdf53 lossless, cdf97 lossy)");
    cmd->add_option("--levels", a->levels, "Transform levels (default 4)");
    cmd->add_option("--brick", a->brick, "Brick size B or X,Y,Z, multiples of 2^levels (default 64)");
    cmd->add_option("--entropy", a->entropy, "fast (zstd over byte planes) or dense (context-modelled rANS, default)");
    cmd->add_option("--threads", a->threads, "Host threads for entropy coding (default 2)");
    cmd->add_flag("--profile", a->profile, "Print the time of each pipeline stage");
    cmd->add_flag("!--no-lod-stats", a->lodStats,
                  "Leave out the per-brick, per-level error statistics renderers use for --lod auto");
    cmd->add_option("--gop", a->gop, "Series: frames per group, each starting with an I frame (default 10)");
    cmd->add_option("--b-frames", a->bFrames, "Series: B frames between two I/P frames (default 0)");
    cmd->add_option("--motion", a->motion,
                    "Series: block (motion-compensated P/B frames, default) or none (every frame an I frame)");
    cmd->add_flag("!--no-global-shift", a->globalShift,
                  "Series: P frames use block motion alone, never a global sub-voxel translation of the "
                  "reference (files that decoders before it read)");
    a->raw.add(*cmd);
    cmd->callback([a, cmd, &global] {
        const CodecOptions o = toOptions(*a, *cmd);
        if (!isVcz(a->out)) throw UsageError("output " + a->out + " must end in .vcz");
        // A second thread reads the input while the OpenCL platform starts: in a one-shot run its start
        // (loading the driver's compiler libraries) is a fixed cost of the same order as reading a 35 MB
        // volume. The platform starts on this thread, not the short-lived one: the driver's LLVM installs an
        // alternate signal stack on the thread that loads it, and AddressSanitizer aborts when such a
        // thread exits.
        std::vector<std::filesystem::path> inputs;
        std::future<SeriesInput> reading = std::async(std::launch::async, [a, &inputs] {
            return readSeriesInputs(a->in, a->raw.toReadOptions(), &inputs);
        });
        ComputeContext cc(global.device);
        SeriesInput input = reading.get();
        TimeSeries& ts = input.series;
        // Every file the inputs consist of (headers and the data files they name) must survive the write.
        checkNotSameFile(inputs, {std::filesystem::path(a->out)});
        // A NIfTI source's orientation, units, intent and scaling travel in the .vcz for NIfTI outputs.
        CodecOptions withMeta = o;
        if (const auto nifti = readNiftiMetadataIfNifti(input.sources.front().file))
            withMeta.metadata[std::string(kVczNiftiMetadataKey)] = niftiMetadataToText(*nifti);
        EncodeReport rep;
        Stopwatch sw;
        std::vector<FrameReport> frames;
        std::vector<std::byte> bytes =
            ts.frames.size() == 1 ? encodeVolume(cc, ts.frames[0], withMeta, &rep)
                                  : encodeSeries(cc, ts, withMeta, &frames);
        const double ms = sw.milliseconds();
        // Per brick and level: range and deviation from the input, for renderers' level of detail.
        Stopwatch lodSw;
        if (a->lodStats) bytes = addLodStatistics(cc, std::move(bytes), ts.frames, a->out);
        const double lodMs = lodSw.milliseconds();
        AtomicFile out(a->out);
        out.write(bytes);
        out.commit();
        if (!global.quiet) {
            std::size_t raw = 0, voxels = 0;
            for (const Volume& v : ts.frames) {
                raw += v.byteSize();
                voxels += v.voxelCount();
            }
            std::cerr << "volcl: wrote " << a->out << ": " << bytes.size() << " bytes, ratio "
                      << formatFixed(double(raw) / double(bytes.size()), 2) << ":1, "
                      << formatFixed(double(bytes.size()) * 8 / double(voxels), 3) << " bits/voxel";
            if (ts.frames.size() == 1 && o.rate != RateMode::Lossless) {
                std::cerr << ", PSNR " << formatFixed(rep.psnr, 2) << " dB, max error " << rep.maxError;
                // Only --max-error stores voxels exactly (to hold its bound); elsewhere the count is 0.
                if (o.rate == RateMode::MaxError) std::cerr << " (" << rep.corrections << " voxels stored exactly)";
            }
            std::cerr << ", " << formatFixed(double(raw) / 1e3 / ms, 1) << " MB/s";
            if (a->lodStats) std::cerr << " (+ " << formatFixed(lodMs, 0) << " ms of level-of-detail statistics)";
            std::cerr << '\n';
            if (!frames.empty()) {
                std::size_t count[3] = {0, 0, 0}, fallbacks = 0;
                double worst = INFINITY, maxErr = 0;
                for (const FrameReport& f : frames) {
                    ++count[static_cast<int>(f.type)];
                    fallbacks += f.intraFallback;
                    if (!std::isnan(f.psnr)) worst = std::min(worst, f.psnr);
                    if (!std::isnan(f.maxError)) maxErr = std::max(maxErr, f.maxError);
                }
                std::cerr << "volcl: " << frames.size() << " frames: " << count[0] << " I, " << count[1] << " P, "
                          << count[2] << " B (" << fallbacks << " planned P/B coded as I)";
                if (o.rate != RateMode::Lossless)
                    std::cerr << ", lowest frame PSNR " << formatFixed(worst, 2) << " dB, max error " << maxErr;
                std::cerr << '\n';
            }
            if (a->profile && ts.frames.size() == 1) printProfile("encode", rep.profile, 0);
        }
    });
}

void addDecode(CLI::App& app, GlobalOptions& global) {
    auto* cmd = app.add_subcommand("decode", "Decompress a .vcz file (whole, a region, or a coarser level)");
    struct Args {
        std::string in, out, region;
        int level = 0;
        std::size_t frame = 0;
        unsigned threads = 2;
        bool profile = false;
    };
    auto a = std::make_shared<Args>();
    cmd->add_option("input", a->in, "Input .vcz file")->required();
    cmd->add_option("-o,--output", a->out,
                    "Output volume: .raw, .nrrd, .nhdr, .nii, .nii.gz (a NIfTI source's header restored), .vti or .vdb")
        ->required();
    cmd->add_option("--region", a->region,
                    "Voxel box x0,y0,z0:x1,y1,z1 (half-open, full-resolution indices)");
    cmd->add_option("--level", a->level, "2^k-downsampled approximation without decoding finer detail");
    cmd->add_option("--frame", a->frame,
                    "Frame of a time series (default 0); an output name with a printf pattern (frames_%03d.nrrd) "
                    "writes every frame");
    cmd->add_option("--threads", a->threads, "Host threads for entropy decoding (default 2)");
    cmd->add_flag("--profile", a->profile, "Print the time of each pipeline stage");
    cmd->callback([a, &global] {
        checkNotSameFile({std::filesystem::path(a->in)}, volumeFilesWritten(a->out));
        DecodeOptions o;
        CodecProfile prof;
        if (a->profile) o.profile = &prof;
        if (!a->region.empty()) o.region = parseRegion(a->region);
        o.level = a->level;
        o.frame = a->frame;
        o.threads = std::max(1u, a->threads);
        VczReader r(readFileBytes(a->in), a->in);
        // A one-shot decode of a whole frame starts entropy decoding on a second thread while this one starts
        // the OpenCL platform, which would otherwise leave a core idle.
        auto pool = std::make_shared<HostMemoryPool>();
        std::optional<DecodeAhead> ahead;
        if (a->out.find('%') == std::string::npos && !o.region && o.level == 0) ahead.emplace(r, o.frame, pool);
        o.ahead = ahead ? &*ahead : nullptr;
        ComputeContext cc(global.device, pool);
        // A NIfTI source's header, kept in the .vcz, goes back into NIfTI outputs.
        WriteOptions wo;
        if (const auto it = r.header().metadata.find(std::string(kVczNiftiMetadataKey)); it != r.header().metadata.end())
            wo.nifti = niftiMetadataFromText(it->second, a->in);
        if (a->out.find('%') != std::string::npos) {
            // A printf pattern: every frame, each decoded once (P/B frames from the frames already decoded).
            const std::size_t n = r.header().frames.size();
            const std::vector<std::string> names = io::expandFilePattern(a->out, 0, static_cast<long long>(n) - 1, 1,
                                                                     a->out, n);
            for (const std::string& name : names)
                checkNotSameFile({std::filesystem::path(a->in)}, volumeFilesWritten(name));
            // A frame is kept until the last frame that references it is decoded.
            std::vector<std::size_t> lastUse(n);
            for (std::size_t f = 0; f < n; ++f) {
                lastUse[f] = f;
                for (std::int32_t ref : {r.header().frames[f].reference0, r.header().frames[f].reference1})
                    if (ref >= 0) lastUse[std::size_t(ref)] = std::max(lastUse[std::size_t(ref)], f);
            }
            std::vector<std::optional<Volume>> frames(n);
            std::vector<const Volume*> known(n, nullptr);
            for (std::size_t f = 0; f < n; ++f) {
                frames[f] = r.decodeFrame(cc, f, known, o.threads, o.profile);
                known[f] = &*frames[f];
                writeVolumeFile(*frames[f], names[f], wo);
                for (std::size_t g = 0; g <= f; ++g)
                    if (frames[g] && lastUse[g] <= f) {
                        frames[g].reset();
                        known[g] = nullptr;
                    }
            }
            if (!global.quiet) std::cerr << "volcl: wrote " << n << " frames to " << a->out << "\n";
            if (a->profile && !global.quiet) printProfile("decode", prof, 0);
            return;
        }
        const Volume v = r.decode(cc, o);
        writeVolumeFile(v, a->out, wo);
        if (!global.quiet)
            std::cerr << "volcl: wrote " << a->out << " (" << v.dims().x << "x" << v.dims().y << "x"
                      << v.dims().z << " " << scalarTypeName(v.type()) << ")\n";
        if (a->profile && !global.quiet) printProfile("decode", prof, 0);
    });
}

/// A plain volume seen the way a .vcz decode at `level` over `region` sees it: encoded with the other
/// side's transform (wavelet, levels, brick; lossless where the transform is integer, else a float
/// transform with a negligible error bound) and decoded at that level, so both sides share one low band.
Volume levelView(ComputeContext& cc, const Volume& v, const VczHeader* like, const DecodeOptions& d) {
    CodecOptions o;
    if (like) {
        o.wavelet = like->wavelet;
        o.levels = like->levels;
        o.brick = like->brick;
    }
    const bool integer = !like || like->transform != TransformKind::FloatLifting;
    if (integer && v.type() != ScalarType::Float32) {
        o.rate = RateMode::Lossless;
    } else {
        const VolumeStats st = v.stats(1);
        o.rate = RateMode::MaxError;
        o.target = std::max(1e-6 * (st.max - st.min), 1e-12);
        if (!like) o.wavelet = Wavelet::Cdf97;
    }
    const std::vector<std::byte> bytes = encodeVolume(cc, v, o);
    return decodeVolume(cc, bytes, d, "reference");
}

void addCompare(CLI::App& app, GlobalOptions& global) {
    auto* cmd = app.add_subcommand("compare", "PSNR, RMSE and max error of B against A (B may be a .vcz)");
    struct Args {
        std::string a, b, region;
        int level = 0;
        std::size_t frame = 0;
        bool json = false;
    };
    auto a = std::make_shared<Args>();
    cmd->add_option("a", a->a, "Reference volume")->required();
    cmd->add_option("b", a->b, "Volume or .vcz to compare")->required();
    cmd->add_option("--level", a->level,
                    "Compare 2^k-downsampled approximations: a .vcz side decodes at level k, a plain volume "
                    "takes the same wavelet low band")
        ->capture_default_str();
    cmd->add_option("--region", a->region, "Compare only the voxel box x0,y0,z0:x1,y1,z1 (half-open, full resolution)");
    cmd->add_option("--frame", a->frame, "Frame of a time series .vcz")->capture_default_str();
    cmd->add_flag("--json", a->json, "JSON output");
    cmd->callback([a, &global] {
        std::unique_ptr<ComputeContext> cc;
        if (isVcz(a->a) || isVcz(a->b) || a->level > 0) cc = std::make_unique<ComputeContext>(global.device);
        if (a->level < 0) throw UsageError("--level must be >= 0");
        DecodeOptions d;
        d.level = a->level;
        d.frame = a->frame;
        if (!a->region.empty()) d.region = parseRegion(a->region);
        std::size_t vczBytes = 0;
        std::optional<VczReader> ra, rb;
        if (isVcz(a->a)) ra.emplace(readFileBytes(a->a), a->a);
        if (isVcz(a->b)) {
            rb.emplace(readFileBytes(a->b), a->b);
            vczBytes = rb->fileSize();
        }
        const VczHeader* like = rb ? &rb->header() : (ra ? &ra->header() : nullptr);
        // Two plain volumes of different sizes under --level: the smaller is already a level decode (what the
        // dimension error's hint suggests comparing), so only the larger is taken to the level.
        std::optional<Volume> plainA, plainB;
        if (!ra) plainA = readVolume(a->a);
        if (!rb) plainB = readVolume(a->b);
        bool coarsenA = a->level > 0, coarsenB = a->level > 0;
        if (a->level > 0 && plainA && plainB && plainA->dims() != plainB->dims()) {
            coarsenA = plainA->voxelCount() > plainB->voxelCount();
            coarsenB = !coarsenA;
        }
        auto load = [&](const std::string& path, std::optional<VczReader>& r, std::optional<Volume>& plain,
                        bool coarsen) {
            if (r) return r->decode(*cc, d);
            Volume v = std::move(*plain);
            if (coarsen) return levelView(*cc, v, like, d);
            if (a->level > 0) return v;
            if (d.region) {
                if (!(d.region->hi.x <= v.dims().x && d.region->hi.y <= v.dims().y && d.region->hi.z <= v.dims().z))
                    throw UsageError("--region " + a->region + " lies outside " + path);
                return v.cropped(d.region->lo, d.region->hi);
            }
            return v;
        };
        const Volume va = load(a->a, ra, plainA, coarsenA);
        const Volume vb = load(a->b, rb, plainB, coarsenB);
        if (va.dims() != vb.dims())
            throw UsageError(a->a + " and " + a->b + " differ in dimensions (" + std::to_string(va.dims().x) + "x" +
                             std::to_string(va.dims().y) + "x" + std::to_string(va.dims().z) + " against " +
                             std::to_string(vb.dims().x) + "x" + std::to_string(vb.dims().y) + "x" +
                             std::to_string(vb.dims().z) + "): give --level K to compare a level decode with its source");
        const double p = psnr(va, vb), r = rmse(va, vb), m = maxAbsError(va, vb);
        const double bpv = vczBytes ? double(vczBytes) * 8 / double(va.voxelCount()) : NAN;
        if (a->json) {
            nlohmann::json j{
                {"a", a->a}, {"b", a->b}, {"psnr_db", jsonNumber(p)}, {"rmse", r}, {"max_abs_error", m}};
            if (vczBytes) {
                j["bits_per_voxel"] = bpv;
                j["ratio"] = double(va.byteSize()) / double(vczBytes);
            }
            std::cout << j.dump(2) << '\n';
        } else {
            std::cout << "psnr_db " << formatFixed(p, 3) << "\nrmse " << r << "\nmax_abs_error " << m << '\n';
            if (vczBytes) std::cout << "bits_per_voxel " << formatFixed(bpv, 4) << '\n';
        }
    });
}

// ------------------------------------------------------------------------------ bench codec

struct BenchData {
    std::string name;
    Volume volume;
    bool realScan = false; ///< CT/MRI: the lossless ratio goal against xz -9 applies
};

Volume readGzipRaw(const fs::path& p, Dims d, ScalarType t) {
    Volume v(d, t);
    gzFile f = gzopen(p.string().c_str(), "rb");
    if (!f) throw IoError(p.string() + ": cannot open");
    const int n = gzread(f, v.bytes().data(), static_cast<unsigned>(v.byteSize()));
    char extra;
    const int more = gzread(f, &extra, 1);
    gzclose(f);
    if (n != static_cast<int>(v.byteSize()) || more != 0)
        throw IoError(p.string() + ": unexpected size after gunzip");
    return v;
}

std::vector<BenchData> loadBenchData(const fs::path& shared, const std::string& filter, bool withLarge) {
    std::vector<BenchData> out;
    auto want = [&](const std::string& n) { return filter.empty() || n.find(filter) != std::string::npos; };
    auto add = [&](const std::string& name, const std::function<Volume()>& load, bool scan) {
        if (!want(name)) return;
        try {
            out.push_back({name, load(), scan});
        } catch (const Error& e) {
            std::cerr << "volcl bench codec: skipping " << name << ": " << e.what() << '\n';
        }
    };
    const fs::path r = shared / "regular";
    if (fs::is_directory(r)) {
        add(
            "hydrogenatom", [&] { return readVolume(r / "hydrogenatom.dat"); }, false);
        add(
            "walnut-ct", [&] { return readVolume(r / "walnut.vvd"); }, true);
        add(
            "headsq-ct", [&] { return readVolume(r / "headsq/quarter.nhdr"); }, true);
        add(
            "brainweb-mri",
            [&] {
                return readGzipRaw(r / "t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz",
                                   {180, 216, 180}, ScalarType::UInt8);
            },
            true);
        add(
            "head-mri-small", [&] { return readVolume(r / "HeadMRVolume.mhd"); }, true);
        if (withLarge)
            add(
                "frog-labels", [&] { return readVolume(r / "froggy/frogtissue.mhd"); }, false);
    } else {
        std::cerr << "volcl bench codec: " << shared.string()
                  << " is absent: skipping the shared data sets\n";
    }
    const fs::path t = shared / "timevarying";
    if (fs::is_directory(t)) {
        add(
            "isabel-02", [&] { return readVolume(t / "isabel/isabel_02.vti"); }, false);
        add(
            "isabel-30", [&] { return readVolume(t / "isabel/isabel_30.vti"); }, false);
        add(
            "viscous-005", [&] { return readVolume(t / "viscousfingers/005_density_005_064_2.0.vti"); },
            false);
        add(
            "viscous-015", [&] { return readVolume(t / "viscousfingers/015_density_015_064_2.0.vti"); },
            false);
    }
    const fs::path mri = "/usr/share/mricron/templates/ch2better.nii.gz";
    if (fs::exists(mri))
        add(
            "ch2better-mri", [&] { return readVolume(mri); }, true);
    else if (want("ch2better-mri"))
        std::cerr << "volcl bench codec: " << mri << " is absent (apt-get install mricron-data): skipping\n";
    return out;
}

struct BenchRow {
    std::string dataset, codec, mode;
    double ratio = 0, bpv = 0, psnr = 0, maxError = 0, encodeMBs = 0, decodeMBs = 0;
    /// A fresh `volcl encode` / `volcl decode` process per run (wall time of the whole command, file read
    /// and write included): what a user running the command once per file sees. 0 when not measured.
    double encodeColdMBs = 0, decodeColdMBs = 0;
};

// Wall milliseconds of one run of this executable with `args` (stdout and stderr to /dev/null); throws
// when it cannot start or does not exit with 0.
double runSelfMilliseconds(const std::vector<std::string>& args) {
    static const std::string exe = fs::read_symlink("/proc/self/exe").string();
    std::vector<char*> argv;
    argv.push_back(const_cast<char*>(exe.c_str()));
    for (const std::string& s : args)
        argv.push_back(const_cast<char*>(s.c_str()));
    argv.push_back(nullptr);
    posix_spawn_file_actions_t io;
    posix_spawn_file_actions_init(&io);
    posix_spawn_file_actions_addopen(&io, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&io, 2, "/dev/null", O_WRONLY, 0);
    Stopwatch sw;
    pid_t pid = 0;
    const int started = posix_spawn(&pid, exe.c_str(), &io, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&io);
    if (started != 0) throw Error("bench codec: cannot start " + exe + " for a cold run");
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    const double ms = sw.milliseconds();
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
        throw Error("bench codec: cold run `volcl " + args.front() + " ...` failed (status " +
                    std::to_string(status) + ")");
    return ms;
}

// Temporary files of the cold runs, removed however the benchmark ends.
struct ColdFiles {
    fs::path volume, vcz, decoded;
    explicit ColdFiles(const fs::path& dir) {
        const std::string stem = "volcl-bench-cold-" + std::to_string(getpid());
        volume = dir / (stem + ".nrrd");
        vcz = dir / (stem + ".vcz");
        decoded = dir / (stem + "-decoded.raw");
    }
    ColdFiles(const ColdFiles&) = delete;
    ColdFiles& operator=(const ColdFiles&) = delete;
    ~ColdFiles() {
        std::error_code ec;
        for (const fs::path& p : {volume, vcz, decoded})
            fs::remove(p, ec);
    }
};

// zfp on the same voxels: reversible on int32 copies of integer data, fixed accuracy on float copies.
struct ZfpResult {
    std::size_t bytes = 0;
    Volume decoded;
    double encodeMs = 0, decodeMs = 0;
};

ZfpResult runZfp(const Volume& v, std::optional<double> tolerance, int runs) {
    const Dims d = v.dims();
    const bool reversible = !tolerance;
    std::vector<std::int32_t> ints;
    std::vector<float> floats;
    if (reversible && v.type() != ScalarType::Float32) {
        ints.resize(v.voxelCount());
        for (std::size_t i = 0; i < ints.size(); ++i)
            ints[i] = static_cast<std::int32_t>(v.valueAt(i));
    } else {
        floats = v.toFloat();
    }
    void* data = ints.empty() ? static_cast<void*>(floats.data()) : static_cast<void*>(ints.data());
    const zfp_type type = ints.empty() ? zfp_type_float : zfp_type_int32;
    zfp_field* field = zfp_field_3d(data, type, d.x, d.y, d.z);
    zfp_stream* zs = zfp_stream_open(nullptr);
    if (reversible)
        zfp_stream_set_reversible(zs);
    else
        zfp_stream_set_accuracy(zs, *tolerance);
    std::vector<unsigned char> buffer(zfp_stream_maximum_size(zs, field));
    bitstream* bs = stream_open(buffer.data(), buffer.size());
    zfp_stream_set_bit_stream(zs, bs);
    ZfpResult r;
    const bool omp = zfp_stream_set_execution(zs, zfp_exec_omp);
    r.encodeMs = medianMilliseconds(runs, [&] {
        zfp_stream_rewind(zs);
        r.bytes = zfp_compress(zs, field);
    });
    if (omp) zfp_stream_set_execution(zs, zfp_exec_serial); // zfp 1.0 decompresses serially
    std::vector<std::int32_t> outInts(ints.size());
    std::vector<float> outFloats(floats.size());
    zfp_field* outField =
        zfp_field_3d(ints.empty() ? static_cast<void*>(outFloats.data()) : static_cast<void*>(outInts.data()),
                     type, d.x, d.y, d.z);
    r.decodeMs = medianMilliseconds(runs, [&] {
        zfp_stream_rewind(zs);
        zfp_decompress(zs, outField);
    });
    zfp_field_free(outField);
    zfp_field_free(field);
    zfp_stream_close(zs);
    stream_close(bs);
    if (r.bytes == 0) throw Error("zfp compression failed");
    Volume out(d, ScalarType::Float32);
    auto o = out.values<float>();
    for (std::size_t i = 0; i < o.size(); ++i)
        o[i] = ints.empty() ? outFloats[i] : static_cast<float>(outInts[i]);
    r.decoded = std::move(out);
    return r;
}

// PSNR of a float decode against the volume, with integer data rounded and clamped like a real decoder.
double psnrAsType(const Volume& v, const Volume& decodedFloat) {
    return psnr(v, decodedFloat.convertedTo(v.type()));
}

// zfp accuracy tolerance that reaches `target` dB (bisection on log tolerance; largest tolerance meeting it).
ZfpResult zfpAtPsnr(const Volume& v, double target, int runs) {
    const VolumeStats st = v.stats(1);
    const double range = std::max(st.max - st.min, 1e-30);
    double lo = std::log2(range) - 40, hi = std::log2(range);
    double best = lo;
    for (int it = 0; it < 18; ++it) {
        const double mid = 0.5 * (lo + hi);
        ZfpResult r = runZfp(v, std::exp2(mid), 0);
        if (psnrAsType(v, r.decoded) >= target) {
            best = mid;
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return runZfp(v, std::exp2(best), runs);
}

std::size_t zstdSize(const Volume& v, int level, double& ms, double& decMs, int runs) {
    std::vector<char> out(ZSTD_compressBound(v.byteSize()));
    std::size_t n = 0;
    ms = medianMilliseconds(
        runs, [&] { n = ZSTD_compress(out.data(), out.size(), v.bytes().data(), v.byteSize(), level); });
    if (ZSTD_isError(n)) throw Error("zstd failed");
    std::vector<char> back(v.byteSize());
    decMs = medianMilliseconds(runs, [&] { ZSTD_decompress(back.data(), back.size(), out.data(), n); });
    return n;
}

// xz -9 through the xz binary (the general-purpose reference ratio); one run, single-threaded.
std::size_t xzSize(const Volume& v, const fs::path& tmpDir, double& ms) {
    const fs::path in = tmpDir / "volcl-bench-xz.raw";
    {
        std::ofstream f(in, std::ios::binary);
        f.write(reinterpret_cast<const char*>(v.bytes().data()), static_cast<std::streamsize>(v.byteSize()));
    }
    Stopwatch sw;
    const std::string cmd = "xz -9 -T1 -c '" + in.string() + "' | wc -c";
    FILE* p = popen(cmd.c_str(), "r");
    std::size_t n = 0;
    if (p) {
        if (std::fscanf(p, "%zu", &n) != 1) n = 0;
        pclose(p);
    }
    ms = sw.milliseconds();
    fs::remove(in);
    return n;
}

struct BenchArgs {
    std::string data = std::string(VOLCL_SOURCE_DIR) + "/../shared/data", filter, csv, json;
    int runs = 3, levels = 4;
    std::size_t brick = 64;
    bool noXz = false, large = false;
    bool cold = true; ///< lossless rows also time a fresh CLI process per run
    std::vector<double> psnrs{30, 40, 50, 60, 70};
    std::vector<std::string> modes; ///< only rows whose mode contains one of these (empty: all)
    std::string coder;              ///< only this entropy coder's rows (empty: both)
    bool wants(const std::string& mode) const {
        return modes.empty() || std::any_of(modes.begin(), modes.end(), [&](const std::string& m) {
                   return mode.find(m) != std::string::npos;
               });
    }
};

void benchCodec(const BenchArgs& a, GlobalOptions& global) {
    ComputeContext cc(global.device);
    std::cerr << "volcl bench codec: device " << cc.device().name << ", median of " << a.runs
              << " runs after a warm-up (kernel builds excluded), 2 host threads\n";
    std::vector<BenchData> sets = loadBenchData(a.data, a.filter, a.large);
    if (sets.empty()) throw UsageError("no data set to benchmark (see --data and --dataset)");
    std::vector<BenchRow> rows;
    nlohmann::json transforms = nlohmann::json::array();
    const fs::path tmp = fs::temp_directory_path();
    for (const BenchData& ds : sets) {
        const Volume& v = ds.volume;
        const double mb = double(v.byteSize()) / 1e6;
        std::optional<ColdFiles> cold;
        if (a.cold) {
            cold.emplace(tmp);
            writeVolumeFile(v, cold->volume);
        }
        const double n = double(v.voxelCount());
        std::cerr << "== " << ds.name << " " << v.dims().x << "x" << v.dims().y << "x" << v.dims().z << " "
                  << scalarTypeName(v.type()) << '\n';
        auto ours = [&](const std::string& mode, CodecOptions o) {
            const std::string coder(entropyName(o.entropy));
            if (!a.wants(mode) || (!a.coder.empty() && a.coder != coder)) return;
            o.levels = a.levels;
            o.brick = {a.brick, a.brick, a.brick};
            EncodeReport rep;
            auto bytes = encodeVolume(cc, v, o, &rep);
            // Time a fixed-step encode for lossy targets: the step search is a one-off cost of the target,
            // and so is the reconstruction that measures the error of a step (--max-error keeps it: it is the
            // bound).
            CodecOptions timed = o;
            if (o.rate != RateMode::Lossless && o.rate != RateMode::MaxError) {
                timed.step = rep.step;
                timed.measureError = false;
            }
            const std::size_t searchTrials = static_cast<std::size_t>(rep.profile.trials);
            Volume out;
            CodecProfile dec;
            const VczReader reader(bytes, ds.name);
            DecodeOptions dopt;
            dopt.profile = &dec;
            auto warmEncode = [&] { bytes = encodeVolume(cc, v, timed, &rep); };
            auto warmDecode = [&] {
                dec = {};
                out = reader.decode(cc, dopt);
            };
            double encMs = 0, decMs = 0, encColdMs = 0, decColdMs = 0, statsMs = 0;
            if (cold && o.rate == RateMode::Lossless) {
                // Cold and warm runs interleaved, so both see the same load; the warm-up run of each side
                // (kernel builds, the on-disk program cache) is not timed.
                std::vector<std::string> global0;
                if (!global.device.empty()) global0 = {"--device", global.device};
                auto with = [&](std::vector<std::string> tail) {
                    std::vector<std::string> all = global0;
                    all.push_back("-q");
                    all.insert(all.end(), tail.begin(), tail.end());
                    return all;
                };
                const std::vector<std::string> enc =
                    with({"encode", cold->volume.string(), "-o", cold->vcz.string(), "--lossless", "--entropy",
                          coder, "--levels", std::to_string(a.levels), "--brick", std::to_string(a.brick)});
                const std::vector<std::string> decArgs = with({"decode", cold->vcz.string(), "-o", cold->decoded.string()});
                warmEncode();
                warmDecode();
                runSelfMilliseconds(enc);
                runSelfMilliseconds(decArgs);
                std::vector<double> we, ws, wd, ce, cd;
                for (int i = 0; i < a.runs; ++i) {
                    Stopwatch sw;
                    warmEncode();
                    we.push_back(sw.milliseconds());
                    // `volcl encode` also measures the level-of-detail statistics by default: the cold
                    // encode is compared with the same work done in process.
                    sw.restart();
                    (void)addLodStatistics(cc, bytes, std::span<const Volume>(&v, 1), ds.name);
                    ws.push_back(sw.milliseconds());
                    ce.push_back(runSelfMilliseconds(enc));
                    sw.restart();
                    warmDecode();
                    wd.push_back(sw.milliseconds());
                    cd.push_back(runSelfMilliseconds(decArgs));
                }
                encMs = median(we);
                statsMs = median(ws);
                decMs = median(wd);
                encColdMs = median(ce);
                decColdMs = median(cd);
            } else {
                encMs = medianMilliseconds(a.runs, warmEncode);
                decMs = medianMilliseconds(a.runs, warmDecode);
            }
            BenchRow r{ds.name, std::string("volcl-") + coder, mode};
            if (encColdMs > 0) {
                r.encodeColdMBs = mb / (encColdMs / 1e3);
                r.decodeColdMBs = mb / (decColdMs / 1e3);
            }
            r.ratio = double(v.byteSize()) / double(bytes.size());
            r.bpv = double(bytes.size()) * 8 / n;
            r.psnr = psnr(v, out);
            r.maxError = maxAbsError(v, out);
            r.encodeMBs = mb / (encMs / 1e3);
            r.decodeMBs = mb / (decMs / 1e3);
            if (o.rate == RateMode::Lossless && !(out == v))
                throw Error(ds.name + ": lossless round trip is not exact");
            rows.push_back(r);
            std::cerr << "  " << r.codec << " " << mode << ": ratio " << formatFixed(r.ratio, 2) << " bpv "
                      << formatFixed(r.bpv, 3) << " PSNR " << formatFixed(r.psnr, 2) << " maxerr " << r.maxError << " enc "
                      << formatFixed(r.encodeMBs, 1) << " MB/s dec " << formatFixed(r.decodeMBs, 1) << " MB/s\n";
            if (encColdMs > 0)
                std::cerr << "    cold (a fresh volcl process per run, file read and write included): encode "
                          << formatFixed(encColdMs, 1) << " ms = " << formatFixed(r.encodeColdMBs, 1) << " MB/s against warm "
                          << formatFixed(encMs + statsMs, 1) << " ms = encode " << formatFixed(encMs, 1)
                          << " + level-of-detail statistics " << formatFixed(statsMs, 1) << " (cold/warm "
                          << formatFixed(encColdMs / (encMs + statsMs), 2) << "), decode "
                          << formatFixed(decColdMs, 1) << " ms = " << formatFixed(r.decodeColdMBs, 1) << " MB/s against warm "
                          << formatFixed(decMs, 1) << " ms (cold/warm " << formatFixed(decColdMs / decMs, 2) << ")\n";
            printProfile("enc", rep.profile, searchTrials);
            printProfile("dec", dec, 0);
        };
        const bool integer = v.type() != ScalarType::Float32;
        CodecOptions o;
        o.rate = RateMode::Lossless;
        for (EntropyMode m : {EntropyMode::Dense, EntropyMode::Fast}) {
            o.entropy = m;
            ours("lossless", o);
        }
        const bool lossless = a.wants("lossless");
        if (integer && lossless) {
            ZfpResult z = runZfp(v, std::nullopt, a.runs);
            BenchRow r{ds.name, "zfp", "lossless"};
            r.ratio = double(v.byteSize()) / double(z.bytes);
            r.bpv = double(z.bytes) * 8 / n;
            r.psnr = psnr(v, z.decoded.convertedTo(v.type()));
            r.maxError = maxAbsError(v, z.decoded);
            r.encodeMBs = mb / (z.encodeMs / 1e3);
            r.decodeMBs = mb / (z.decodeMs / 1e3);
            rows.push_back(r);
            std::cerr << "  zfp reversible: ratio " << formatFixed(r.ratio, 2) << " enc " << formatFixed(r.encodeMBs, 1)
                      << " dec " << formatFixed(r.decodeMBs, 1) << '\n';
        }
        for (int level : {3, 19}) {
            if (!lossless) break;
            double ms = 0, dms = 0;
            const std::size_t bytes = zstdSize(v, level, ms, dms, a.runs);
            BenchRow r{ds.name, "zstd-" + std::to_string(level), "lossless"};
            r.ratio = double(v.byteSize()) / double(bytes);
            r.bpv = double(bytes) * 8 / n;
            r.psnr = INFINITY;
            r.encodeMBs = mb / (ms / 1e3);
            r.decodeMBs = mb / (dms / 1e3);
            rows.push_back(r);
        }
        if (!a.noXz && lossless) {
            double ms = 0;
            const std::size_t bytes = xzSize(v, tmp, ms);
            if (bytes > 0) {
                BenchRow r{ds.name, "xz-9", "lossless"};
                r.ratio = double(v.byteSize()) / double(bytes);
                r.bpv = double(bytes) * 8 / n;
                r.psnr = INFINITY;
                r.encodeMBs = mb / (ms / 1e3);
                rows.push_back(r);
                std::cerr << "  xz -9: ratio " << formatFixed(r.ratio, 2) << '\n';
            }
        }
        // Rate-distortion at equal PSNR: ours (target PSNR) against zfp tuned to the same PSNR.
        for (double p : a.psnrs) {
            if (!a.wants("psnr" + formatFixed(p, 0))) continue;
            CodecOptions lo;
            lo.rate = RateMode::Psnr;
            lo.target = p;
            ours("psnr" + formatFixed(p, 0), lo);
            ZfpResult z = zfpAtPsnr(v, p, a.runs);
            BenchRow r{ds.name, "zfp", "psnr" + formatFixed(p, 0)};
            const Volume zd = integer ? z.decoded.convertedTo(v.type()) : z.decoded;
            r.ratio = double(v.byteSize()) / double(z.bytes);
            r.bpv = double(z.bytes) * 8 / n;
            r.psnr = psnr(v, zd);
            r.maxError = maxAbsError(v, zd);
            r.encodeMBs = mb / (z.encodeMs / 1e3);
            r.decodeMBs = mb / (z.decodeMs / 1e3);
            rows.push_back(r);
            std::cerr << "  zfp psnr" << p << ": bpv " << formatFixed(r.bpv, 3) << " PSNR " << formatFixed(r.psnr, 2) << '\n';
        }
        // The speed goal at 1-2 bits/voxel, with both entropy coders.
        for (EntropyMode m : {EntropyMode::Dense, EntropyMode::Fast})
            for (double bpv : {1.0, 2.0}) {
                CodecOptions lo;
                lo.rate = RateMode::Bpv;
                lo.target = bpv;
                lo.entropy = m;
                ours("bpv" + formatFixed(bpv, 0), lo);
            }
        {
            const VolumeStats st = v.stats(1);
            CodecOptions lo;
            lo.rate = RateMode::MaxError;
            lo.target = std::max((st.max - st.min) * 0.005, integer ? 1.0 : 1e-6);
            ours("maxerr0.5%", lo);
        }
        // Transform only: one level of 3D 5/3 on the codec's bricks, against the copy kernel on the same
        // bytes; the brick-resident kernel (what the codec runs on CPUs) and the streaming passes (the
        // general path) measured in the same run.
        if (a.wants("transform")) {
            Dims bd{std::min<std::size_t>(a.brick, v.dims().x), std::min<std::size_t>(a.brick, v.dims().y),
                    std::min<std::size_t>(a.brick, v.dims().z)};
            const std::size_t count = std::max<std::size_t>(1, v.voxelCount() / bd.count());
            BrickBatch<std::int32_t> batch(cc, bd, count);
            std::vector<std::int32_t> host = batch.makeHost();
            batch.upload(cc, host);
            const double voxels = double(bd.count() * count);
            const double copy = copyKernelBandwidthGBs(cc, batch.brickStride() * count * 4);
            // The codec's choice (brick-resident on CPUs), then the streaming passes when that was not them.
            LiftingTransform<std::int32_t> chosen(cc, Wavelet::Cdf53), streaming(cc, Wavelet::Cdf53);
            streaming.setPath(LiftingPath::Streaming);
            std::vector<LiftingTransform<std::int32_t>*> kernels{&chosen};
            if (chosen.pathFor(batch) != LiftingPath::Streaming) kernels.push_back(&streaming);
            for (LiftingTransform<std::int32_t>* tp : kernels) {
                LiftingTransform<std::int32_t>& t = *tp;
                const char* kernel =
                    t.pathFor(batch) == LiftingPath::Streaming ? "streaming" : "brick-resident";
                t.forward(cc, batch, 1); // warm-up: builds and specialises the kernels
                std::vector<double> ms;
                for (int i = 0; i < std::max(3, a.runs); ++i)
                    ms.push_back(t.forward(cc, batch, 1));
                const double med = median(ms);
                // Bytes of three streaming passes (int32 read + write each): the brick-resident kernel moves
                // less, so its fraction is of the work, not of its own traffic.
                const double gbs = voxels * 3 * 8 / (med * 1e6);
                transforms.push_back({{"dataset", ds.name},
                                      {"transform", "cdf53 1 level 3D"},
                                      {"kernel", kernel},
                                      {"gvoxel_per_s", voxels / (med * 1e6)},
                                      {"gb_per_s", gbs},
                                      {"copy_gb_per_s", copy},
                                      {"fraction_of_copy", gbs / copy}});
                std::cerr << "  transform cdf53 1 level, " << kernel << ": " << formatFixed(voxels / (med * 1e6), 3)
                          << " Gvoxel/s, " << formatFixed(gbs, 1)
                          << " GB/s of pass traffic = " << formatFixed(100 * gbs / copy, 0)
                          << "% of the copy kernel (" << formatFixed(copy, 1) << " GB/s)\n";
            }
        }
    }
    // Output.
    std::ostringstream csv;
    csv << "dataset,codec,mode,ratio,bits_per_voxel,psnr_db,max_abs_error,encode_MBps,decode_MBps,"
           "encode_cold_MBps,decode_cold_MBps\n";
    nlohmann::json j;
    j["device"] = cc.device().name;
    j["runs"] = a.runs;
    j["rows"] = nlohmann::json::array();
    for (const BenchRow& r : rows) {
        csv << r.dataset << ',' << r.codec << ',' << r.mode << ',' << r.ratio << ',' << r.bpv << ','
            << formatFixed(r.psnr, 4) << ',' << r.maxError << ',' << r.encodeMBs << ',' << r.decodeMBs << ','
            << r.encodeColdMBs << ',' << r.decodeColdMBs << '\n';
        j["rows"].push_back({{"dataset", r.dataset},
                             {"codec", r.codec},
                             {"mode", r.mode},
                             {"ratio", r.ratio},
                             {"bits_per_voxel", r.bpv},
                             {"psnr_db", jsonNumber(r.psnr)},
                             {"max_abs_error", r.maxError},
                             {"encode_MBps", r.encodeMBs},
                             {"decode_MBps", r.decodeMBs},
                             {"encode_cold_MBps", r.encodeColdMBs},
                             {"decode_cold_MBps", r.decodeColdMBs}});
    }
    j["transforms"] = transforms;
    if (!a.csv.empty()) {
        AtomicFile f(a.csv);
        f.write(csv.str());
        f.commit();
    } else {
        std::cout << csv.str();
    }
    if (!a.json.empty()) {
        AtomicFile f(a.json);
        f.write(j.dump(1));
        f.commit();
    }
}

} // namespace

void addCodecCommands(CLI::App& app, CLI::App& bench, GlobalOptions& global) {
    addEncode(app, global);
    addDecode(app, global);
    addCompare(app, global);
    auto* b =
        bench.add_subcommand("codec", "Codec: ratio, PSNR, speed against zfp, zstd and xz on real volumes");
    auto a = std::make_shared<BenchArgs>();
    b->add_option("--data", a->data, "Shared data directory")->capture_default_str();
    b->add_option("--dataset", a->filter, "Only data sets whose name contains this text");
    b->add_option("--runs", a->runs, "Timed runs per measurement (median)")->capture_default_str();
    b->add_option("--levels", a->levels, "Transform levels")->capture_default_str();
    b->add_option("--brick", a->brick, "Brick size")->capture_default_str();
    b->add_option("--psnr", a->psnrs, "PSNR targets in dB for the rate-distortion curves");
    b->add_flag("--no-xz", a->noXz, "Skip the (slow) xz -9 reference");
    b->add_flag("--cold,!--no-cold", a->cold,
                "Lossless rows also time a fresh `volcl encode`/`volcl decode` process per run, interleaved "
                "with the warm in-process runs (default on)");
    b->add_flag("--large", a->large, "Include the 500x470x136 frog labels");
    b->add_option("--csv", a->csv, "CSV output file (default: stdout)");
    b->add_option("--json", a->json, "JSON output file");
    b->add_option("--mode", a->modes,
                  "Only rows whose mode contains this text: lossless, psnr50, bpv1, maxerr, transform "
                  "(repeatable; default all)");
    b->add_option("--coder", a->coder, "Only this entropy coder's rows: fast or dense (default both)")
        ->check(CLI::IsMember({"fast", "dense"}));
    b->callback([a, &global] {
        if (a->runs < 1) throw UsageError("--runs must be at least 1");
        benchCodec(*a, global);
    });
}

} // namespace volcl::cli
