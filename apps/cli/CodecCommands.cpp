// `volcl encode`, `volcl decode` and `volcl compare`.
#include "apps/cli/CliParsing.hpp"
#include "apps/cli/CodecReport.hpp"
#include "apps/cli/Commands.hpp"
#include "apps/cli/MeshCodecCommands.hpp"
#include "apps/cli/VczInfo.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/MemoryBudget.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/PeakMemory.hpp"
#include "core/runtime/Timing.hpp"
#include "host/io/IoDetail.hpp"
#include "host/io/NiftiMetadata.hpp"
#include "host/io/Series.hpp"
#include "host/io/SlabReader.hpp"
#include "host/io/VolumeIo.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/LodStatistics.hpp"
#include "wavelet/stream/StreamEncoder.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <future>
#include <iostream>
#include <memory>
#include <optional>

namespace volcl::cli {

namespace {

namespace fs = std::filesystem;

bool isVcz(const fs::path& p) {
    return p.extension() == ".vcz";
}

struct EncodeArgs {
    std::vector<std::string> in; ///< one file, several files, quoted globs or a .pvd: the frames in order
    std::string out, wavelet, entropy = "dense", brick = "64", motion = "block";
    std::size_t gop = 10, bFrames = 0;
    bool lossless = false, profile = false, lodStats = true, globalShift = true, stream = false;
    bool labels = false; ///< --labels: the input is a label map, coded losslessly
    double maxError = 0, relError = 0, pwRelError = 0, psnr = 0, bpv = 0, step = 0;
    int levels = 4;
    unsigned threads = 2;
    RawReadFlags raw;
    int bits = 16; ///< a .vcm output's quantisation
    MeshReadFlags mesh;
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
    if (cmd.count("--rel-error")) {
        ++chosen;
        o.rate = RateMode::RelError;
        o.target = a.relError;
    }
    if (cmd.count("--pw-rel-error")) {
        ++chosen;
        o.rate = RateMode::PwRelError;
        o.target = a.pwRelError;
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
    if (chosen > 1)
        throw UsageError("choose one of --lossless, --max-error, --rel-error, --pw-rel-error, --psnr, --bpv");
    if (cmd.count("--step")) {
        if (o.rate == RateMode::Lossless)
            throw UsageError(
                "--step needs a lossy mode (--max-error, --rel-error, --pw-rel-error, --psnr or --bpv)");
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
    o.chooseExtent = !cmd.count("--brick") && !cmd.count("--levels");
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

/// The NIfTI header of a series' first input, and whether the frames are read as stored integers: every
/// input file a NIfTI with the same scaled integer datatype the model holds (niftiStoredValuesExact), so
/// one scale describes them all. Inputs that cannot be listed or read here fail when they are read.
struct NiftiSource {
    std::optional<NiftiMetadata> meta;
    bool stored = false;
};

NiftiSource niftiSourceOf(const std::vector<std::string>& in, const ReadOptions& options) {
    NiftiSource s;
    try {
        const std::vector<fs::path> files = expandSeriesInputs(in, options);
        if (files.empty()) return s;
        s.meta = readNiftiMetadataIfNifti(files.front());
        if (!s.meta || !niftiStoredValuesExact(*s.meta)) return s;
        for (const fs::path& f : files) {
            const auto m = f == files.front() ? s.meta : readNiftiMetadataIfNifti(f);
            if (!m || m->datatype != s.meta->datatype || m->sclSlope != s.meta->sclSlope ||
                m->sclInter != s.meta->sclInter)
                return s;
        }
        s.stored = true;
    } catch (const Error&) {
        s = {};
    }
    return s;
}

/// The options with a NIfTI source's header and value mode in the metadata, and --max-error in stored units
/// (stored integers are 1/|scl_slope| data units apart).
CodecOptions withSourceMetadata(const CodecOptions& o, const NiftiSource& nifti) {
    CodecOptions withMeta = o;
    if (nifti.meta) withMeta.metadata[std::string(kVczNiftiMetadataKey)] = niftiMetadataToText(*nifti.meta);
    if (nifti.stored) withMeta.metadata[std::string(kVczNiftiValuesKey)] = "stored";
    const double unit = nifti.stored ? std::abs(static_cast<double>(nifti.meta->sclSlope)) : 1.0;
    if (withMeta.rate == RateMode::MaxError) withMeta.target /= unit;
    // |stored| is proportional to |data| only when nothing is added to the scaled values.
    if (withMeta.rate == RateMode::PwRelError && nifti.stored && nifti.meta->sclInter != 0)
        throw UsageError("--pw-rel-error on a NIfTI with scl_inter " + formatNumber(nifti.meta->sclInter) +
                         ": the bound would not be relative to the data values (use --rel-error or "
                         "--max-error)");
    return withMeta;
}

/// Encodes the input one brick row at a time (encodeStreaming over a VolumeSlabReader) when it can and
/// should be: one lossless integer raw/NRRD/NIfTI file, larger than kStreamEncodeAboveBytes decoded or
/// with --stream. Memory holds a brick row (and for gzip data one slab of brick-z slices), never the
/// volume. Returns false when the input is for the whole-volume encoder; with --stream, an input that
/// cannot stream is a usage error saying why.
bool streamEncode(const EncodeArgs& a, const CodecOptions& o, const ReadOptions& ro,
                  const GlobalOptions& global) {
    const auto refuse = [&](const std::string& why) {
        if (a.stream) throw UsageError("--stream: " + why);
        return false;
    };
    if (a.in.size() != 1 || hasGlobPattern(a.in[0])) return refuse("give one input file");
    if (o.rate != RateMode::Lossless) return refuse("streaming encode is lossless only");
    std::optional<VolumeSlabReader> reader = VolumeSlabReader::open(a.in[0], ro);
    if (!reader)
        return refuse(a.in[0] + " is not a 3D raw, NRRD or NIfTI file with raw or gzip data in one file "
                                "(or its values become float: scaled NIfTI)");
    if (isFloatType(reader->type()))
        return refuse(a.in[0] + " holds float voxels (kept as raw bits over the whole volume)");
    const std::size_t decoded = reader->dims().count() * scalarSize(reader->type());
    if (!a.stream && decoded <= kStreamEncodeAboveBytes) return false;
    checkNotSameFile(reader->files(), {std::filesystem::path(a.out)});
    VolumeSource src;
    src.dims = reader->dims();
    src.type = reader->type();
    src.spacing = reader->spacing();
    src.origin = reader->origin();
    src.direction = reader->direction();
    src.anatomical = reader->anatomical();
    src.fill = [&reader](Dims lo, Volume& out) { reader->read(lo, out); };
    Stopwatch sw;
    ComputeContext cc(global.device);
    AtomicFile out(a.out);
    const StreamEncodeReport r = encodeStreaming(cc, src, o, a.lodStats, out.stream(), a.out);
    out.commit();
    if (!global.quiet)
        std::cerr << "volcl: wrote " << a.out << ": " << r.bytes << " bytes, ratio "
                  << formatFixed(double(decoded) / double(r.bytes), 2) << ":1, "
                  << formatFixed(double(r.bytes) * 8 / double(src.dims.count()), 3)
                  << " bits/voxel, streamed in " << r.rows << " brick rows of at most " << r.rowBytes
                  << " bytes" << (reader->gzip() ? " (gzip input: one slab of a brick's depth held)" : "")
                  << ", " << formatFixed(double(decoded) / 1e3 / sw.milliseconds(), 1) << " MB/s, peak RSS "
                  << peakResidentBytes() / (1024 * 1024) << " MiB\n";
    return true;
}

void addEncode(CLI::App& app, GlobalOptions& global) {
    auto* cmd = app.add_subcommand("encode", "Compress a volume into a .vcz file (wavelet lifting codec)");
    auto a = std::make_shared<EncodeArgs>();
    cmd->add_option("input", a->in,
                    "Input volume(s): one file (a 4D file keeps its frames), several files in frame order, a "
                    "quoted glob ('run_*.vti', natural order) or a ParaView .pvd")
        ->required();
    cmd->add_option("-o,--output", a->out,
                    "Output .vcz file, or .vcm for a tetrahedral mesh input (cut-border mesh compression)")
        ->required();
    cmd->add_flag("--lossless", a->lossless,
                  "Bit-exact (default; a .vcm: float64 positions, float32 scalars)");
    cmd->add_flag(
        "--labels", a->labels,
        "The input is a label map (as NIfTI intent NIFTI_INTENT_LABEL marks one): coded losslessly, "
        "lossy rates refused");
    cmd->add_option(
        "--bits", a->bits,
        "A .vcm: quantisation bits per coordinate and scalar, 1-30 (default 16; error at most half a "
        "step of the bounding box per axis)");
    cmd->add_option("--max-error", a->maxError,
                    "Lossy: every voxel within E of the input (guaranteed; data units of a scaled NIfTI)");
    cmd->add_option("--rel-error", a->relError,
                    "Lossy: every finite voxel within R x (max - min) of the finite values (guaranteed)");
    cmd->add_option("--pw-rel-error", a->pwRelError,
                    "Lossy: every voxel within R x |voxel|, 0 < R < 1 (guaranteed; zeros exact, signs kept)");
    cmd->add_option("--psnr", a->psnr,
                    "Lossy: PSNR in dB over the input's value range (met within " +
                        formatNumber(kPsnrToleranceDb) + " dB)");
    cmd->add_option("--bpv", a->bpv, "Lossy: at most R bits per voxel, file overhead included");
    cmd->add_option("--step", a->step, "Lossy: fixed base quantiser step instead of a search for the target");
    cmd->add_option("--wavelet", a->wavelet,
                    "cdf53 | cdf97 | haar | cdf26 (default cdf53 lossless, cdf97 lossy)");
    cmd->add_option("--levels", a->levels, "Transform levels (default 4)");
    cmd->add_option("--brick", a->brick,
                    "Brick size B or X,Y,Z, multiples of 2^levels (default 64, or 128 where smaller)");
    cmd->add_option("--entropy", a->entropy,
                    "fast (zstd over byte planes) or dense (context-modelled rANS, default)");
    cmd->add_option("--threads", a->threads, "Host threads for entropy coding (default 2)");
    cmd->add_flag("--profile", a->profile, "Print the time of each pipeline stage");
    cmd->add_flag("!--no-lod-stats", a->lodStats,
                  "Leave out the per-brick, per-level error statistics renderers use for --lod auto");
    cmd->add_option("--gop", a->gop, "Series: frames per group, each starting with an I frame (default 10)");
    cmd->add_option("--b-frames", a->bFrames, "Series: B frames between two I/P frames (default 0)");
    cmd->add_option(
        "--motion", a->motion,
        "Series: block (motion-compensated P/B frames, default) or none (every frame an I frame)");
    cmd->add_flag("!--no-global-shift", a->globalShift,
                  "Series: P frames use block motion alone, never a global sub-voxel translation of the "
                  "reference (files that decoders before it read)");
    cmd->add_flag("--stream", a->stream,
                  "Read and code the input one brick row at a time whatever its size (done anyway above " +
                      std::to_string(kStreamEncodeAboveBytes >> 20) +
                      " MiB decoded): lossless integer raw/NRRD/NIfTI files; the same bytes as without it");
    a->raw.add(*cmd);
    a->mesh.add(*cmd);
    cmd->callback([a, cmd, &global] {
        if (writesVcm(a->out)) {
            if (a->in.size() != 1) throw UsageError("a .vcm holds one mesh: give one input file");
            if (a->lossless && cmd->count("--bits")) throw UsageError("choose one of --lossless, --bits");
            for (const char* flag : {"--max-error", "--psnr", "--bpv", "--step"})
                if (cmd->count(flag))
                    throw UsageError(std::string(flag) + " applies to .vcz; a .vcm takes --bits");
            encodeMeshCommand(a->in[0], a->out, {a->bits, a->lossless}, a->mesh, global.quiet);
            return;
        }
        if (cmd->count("--bits")) throw UsageError("--bits applies to a .vcm output");
        CodecOptions o = toOptions(*a, *cmd);
        if (!isVcz(a->out)) throw UsageError("output " + a->out + " must end in .vcz");
        // A second thread reads the input while the OpenCL platform starts: in a one-shot run its start
        // (loading the driver's compiler libraries) is a fixed cost of the same order as reading a 35 MB
        // volume. The platform starts on this thread, not the short-lived one: the driver's LLVM installs an
        // alternate signal stack on the thread that loads it, and AddressSanitizer aborts when such a
        // thread exits.
        std::vector<std::filesystem::path> inputs;
        ReadOptions ro = a->raw.toReadOptions();
        const NiftiSource nifti = niftiSourceOf(a->in, ro);
        ro.niftiStoredValues = nifti.stored;
        // A label map's values are names, not measurements: a lossy code would turn one label into another.
        // It is coded losslessly, which meets any error bound or PSNR (palette bricks keep it small); a bit
        // budget or a fixed quantiser cannot be honoured that way and is refused.
        constexpr int kNiftiIntentLabel = 1002;
        if ((a->labels || (nifti.meta && nifti.meta->intentCode == kNiftiIntentLabel)) &&
            o.rate != RateMode::Lossless) {
            const std::string what =
                a->in.front() + ": a label map (" +
                (a->labels ? std::string("--labels") : std::string("NIfTI intent NIFTI_INTENT_LABEL")) + ")";
            if (o.rate == RateMode::Bpv || o.step)
                throw UsageError(what + " is coded losslessly; a bit budget or --step does not apply");
            o.rate = RateMode::Lossless;
            o.target = 0;
            o.wavelet.reset();
            if (!global.quiet) std::cerr << "volcl encode: " << what << " is coded losslessly (exact)\n";
        }
        if (streamEncode(*a, withSourceMetadata(o, nifti), ro, global)) return;
        std::future<SeriesInput> reading =
            std::async(std::launch::async, [a, ro, &inputs] { return readSeriesInputs(a->in, ro, &inputs); });
        ComputeContext cc(global.device);
        SeriesInput input = reading.get();
        TimeSeries& ts = input.series;
        // Every file the inputs consist of (headers and the data files they name) must survive the write.
        checkNotSameFile(inputs, {std::filesystem::path(a->out)});
        // A NIfTI source's orientation, units, intent and scaling travel in the .vcz for NIfTI outputs;
        // a scaled integer source's frames are its stored integers, the scale beside them.
        const CodecOptions withMeta = withSourceMetadata(o, nifti);
        const double unit = nifti.stored ? std::abs(static_cast<double>(nifti.meta->sclSlope)) : 1.0;
        EncodeReport rep;
        Stopwatch sw;
        std::vector<FrameReport> frames;
        // --bpv bounds the whole file: with the statistics, the frames are coded within what they leave.
        const bool statisticsInBudget = a->lodStats && o.rate == RateMode::Bpv;
        std::vector<std::byte> bytes =
            statisticsInBudget      ? encodeWithLodStatistics(cc, ts, withMeta, a->out, &rep, &frames)
            : ts.frames.size() == 1 ? encodeVolume(cc, ts.frames[0], withMeta, &rep)
                                    : encodeSeries(cc, ts, withMeta, &frames);
        const double ms = sw.milliseconds();
        // Per brick and level: range and deviation from the input, for renderers' level of detail.
        Stopwatch lodSw;
        if (a->lodStats && !statisticsInBudget)
            bytes = addLodStatistics(cc, std::move(bytes), ts.frames, a->out);
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
                std::cerr << ", PSNR " << formatFixed(rep.psnr, 2) << " dB, max error "
                          << rep.maxError * unit;
                // Only the bounded modes store voxels exactly (to hold their bound); elsewhere the count is 0.
                if (isBoundedRate(o.rate)) std::cerr << " (" << rep.corrections << " voxels stored exactly)";
            }
            std::cerr << ", " << formatFixed(double(raw) / 1e3 / ms, 1) << " MB/s";
            if (statisticsInBudget)
                std::cerr << " (level-of-detail statistics included)";
            else if (a->lodStats)
                std::cerr << " (+ " << formatFixed(lodMs, 0) << " ms of level-of-detail statistics)";
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
                std::cerr << "volcl: " << frames.size() << " frames: " << count[0] << " I, " << count[1]
                          << " P, " << count[2] << " B (" << fallbacks << " planned P/B coded as I)";
                if (o.rate != RateMode::Lossless)
                    std::cerr << ", lowest frame PSNR " << formatFixed(worst, 2) << " dB, max error "
                              << maxErr * unit;
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
        VtuWriteFlags vtu;
    };
    auto a = std::make_shared<Args>();
    cmd->add_option("input", a->in, "Input .vcz file, or a .vcm mesh (decodes to .vtu)")->required();
    cmd->add_option(
           "-o,--output", a->out,
           "Output volume: .raw, .nrrd, .nhdr, .nii, .nii.gz (3D or 4D; a NIfTI source's header restored), "
           ".vti or .vdb; .vtu for a .vcm mesh")
        ->required();
    cmd->add_option("--region", a->region,
                    "Voxel box x0,y0,z0:x1,y1,z1 (half-open, full-resolution indices)");
    cmd->add_option("--level", a->level, "2^k-downsampled approximation without decoding finer detail");
    cmd->add_option(
        "--frame", a->frame,
        "Frame K of a time series (default: every frame, into a 4D .nii/.nii.gz or a printf pattern "
        "such as frames_%03d.nrrd; other formats need --frame)");
    cmd->add_option("--threads", a->threads, "Host threads for entropy decoding (default 2)");
    cmd->add_flag("--profile", a->profile, "Print the time of each pipeline stage");
    a->vtu.add(*cmd);
    cmd->callback([a, cmd, &global] {
        if (meshcodec::isVcmFile(a->in)) {
            decodeMeshCommand(a->in, a->out, a->vtu, global.quiet);
            return;
        }
        checkNotSameFile({std::filesystem::path(a->in)}, volumeFilesWritten(a->out));
        DecodeOptions o;
        CodecProfile prof;
        if (a->profile) o.profile = &prof;
        if (!a->region.empty()) o.region = parseRegion(a->region);
        o.level = a->level;
        o.frame = a->frame;
        o.threads = std::max(1u, a->threads);
        // Mapped: a region of a file whose frame exceeds the memory budget decodes (decode() budgets the region).
        VczReader r{std::filesystem::path(a->in)};
        const std::size_t n = r.header().frames.size();
        const bool pattern = a->out.find('%') != std::string::npos;
        // A series without --frame goes whole into a format that holds frames; never silently frame 0.
        const bool allFrames = !pattern && n > 1 && cmd->count("--frame") == 0;
        if (allFrames && !formatHoldsSeries(a->out))
            throw UsageError(
                a->out + ": " + a->in + " holds " + std::to_string(n) +
                " frames and this format one volume: write .nii, .nii.gz, .nrrd or .nhdr (all frames), give "
                "--frame K, or a printf pattern (frames_%03d.vti)");
        // A one-shot decode of a whole frame starts entropy decoding on a second thread while this one starts
        // the OpenCL platform, which would otherwise leave a core idle.
        auto pool = std::make_shared<HostMemoryPool>();
        std::optional<DecodeAhead> ahead;
        if (!pattern && !allFrames && !o.region && o.level == 0) ahead.emplace(r, o.frame, pool);
        o.ahead = ahead ? &*ahead : nullptr;
        ComputeContext cc(global.device, pool);
        // A NIfTI source's header (and its stored integers' scale), kept in the .vcz, goes back into
        // NIfTI outputs; other outputs get data units.
        const WriteOptions wo = vczWriteOptions(r.header(), a->in);
        if (pattern) {
            // A printf pattern: every frame, each decoded once (P/B frames from the frames already decoded).
            const std::vector<std::string> names =
                io::expandFilePattern(a->out, 0, static_cast<long long>(n) - 1, 1, a->out, n);
            for (const std::string& name : names)
                checkNotSameFile({std::filesystem::path(a->in)}, volumeFilesWritten(name));
            AtomicCommitGroup frameFiles; // every frame or none: each waits, finished, for the last
            decodeEachFrame(r, cc, o.threads, o.profile,
                            [&](std::size_t f, Volume&& v) { writeVolumeFile(v, names[f], wo); });
            frameFiles.commit();
            if (!global.quiet) std::cerr << "volcl: wrote " << n << " frames to " << a->out << "\n";
            if (a->profile && !global.quiet) printProfile("decode", prof, 0);
            return;
        }
        TimeSeries ts;
        if (allFrames && !o.region && o.level == 0) {
            ts = decodeAllFrames(r, cc, o.threads, o.profile);
        } else if (allFrames) { // a region or a level of every frame
            for (std::size_t f = 0; f < n; ++f) {
                DecodeOptions one = o;
                one.frame = f;
                ts.frames.push_back(r.decode(cc, one));
            }
            ts.times = vczFrameTimes(r.header());
        } else {
            ts.frames.push_back(r.decode(cc, o));
        }
        writeSeriesFile(ts, a->out, wo);
        const Volume& v = ts.frames.front();
        if (!global.quiet)
            std::cerr << "volcl: wrote " << a->out << " (" << v.dims().x << "x" << v.dims().y << "x"
                      << v.dims().z << " " << scalarTypeName(v.type())
                      << (ts.frames.size() > 1 ? ", " + std::to_string(ts.frames.size()) + " frames" : "")
                      << ")\n";
        if (a->profile && !global.quiet) printProfile("decode", prof, 0);
    });
}

/// A plain volume seen the way a .vcz decode at `level` over `region` sees it: encoded with the other
/// side's transform (wavelet, levels, brick; lossless where the transform is integer, else a float
/// transform with a negligible error bound) and decoded at that level, so both sides share one low band.
Volume levelView(ComputeContext& cc, const Volume& v, const VczHeader* like, const DecodeOptions& d) {
    CodecOptions o;
    o.chooseExtent = false; // both sides must share one transform extent
    if (like) {
        o.wavelet = like->wavelet;
        o.levels = like->levels;
        o.brick = like->brick;
    }
    const bool integer = !like || like->transform != TransformKind::FloatLifting;
    if (integer && !isFloatType(v.type())) {
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
    cmd->add_option("--region", a->region,
                    "Compare only the voxel box x0,y0,z0:x1,y1,z1 (half-open, full resolution)");
    cmd->add_option("--frame", a->frame, "Frame of a time series (.vcz or a 4D file; a 3D file is its frame)")
        ->capture_default_str();
    cmd->add_flag("--json", a->json, "JSON output");
    cmd->callback([a, cmd, &global] {
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
        // A 4D file gives frame --frame (a 3D file is that frame), and says so when --frame is not given.
        auto readPlain = [&](const std::string& path) {
            TimeSeries ts = readVolumeFile(path);
            if (ts.frames.size() == 1) return std::move(ts.frames.front());
            if (a->frame >= ts.frames.size())
                throw UsageError("--frame " + std::to_string(a->frame) + " out of range: " + path + " has " +
                                 std::to_string(ts.frames.size()) + " frame(s)");
            if (cmd->count("--frame") == 0 && !global.quiet)
                std::cerr << "volcl compare: frame 0 of the " << ts.frames.size() << " frames of " << path
                          << " (--frame K picks another)\n";
            return std::move(ts.frames[a->frame]);
        };
        if (!ra) plainA = readPlain(a->a);
        if (!rb) plainB = readPlain(a->b);
        bool coarsenA = a->level > 0, coarsenB = a->level > 0;
        if (a->level > 0 && plainA && plainB && plainA->dims() != plainB->dims()) {
            coarsenA = plainA->voxelCount() > plainB->voxelCount();
            coarsenB = !coarsenA;
        }
        auto load = [&](const std::string& path, std::optional<VczReader>& r, std::optional<Volume>& plain,
                        bool coarsen) {
            if (r) { // a scaled NIfTI's stored integers are compared in data units, as the .nii reads
                const WriteOptions wo = vczWriteOptions(r->header(), path);
                Volume v = r->decode(*cc, d);
                return wo.niftiStoredValues ? niftiDataUnits(v, *wo.nifti) : v;
            }
            Volume v = std::move(*plain);
            if (coarsen) return levelView(*cc, v, like, d);
            if (a->level > 0) return v;
            if (d.region) {
                if (!(d.region->hi.x <= v.dims().x && d.region->hi.y <= v.dims().y &&
                      d.region->hi.z <= v.dims().z))
                    throw UsageError("--region " + a->region + " lies outside " + path);
                return v.cropped(d.region->lo, d.region->hi);
            }
            return v;
        };
        const Volume va = load(a->a, ra, plainA, coarsenA);
        const Volume vb = load(a->b, rb, plainB, coarsenB);
        if (va.dims() != vb.dims())
            throw UsageError(a->a + " and " + a->b + " differ in dimensions (" + std::to_string(va.dims().x) +
                             "x" + std::to_string(va.dims().y) + "x" + std::to_string(va.dims().z) +
                             " against " + std::to_string(vb.dims().x) + "x" + std::to_string(vb.dims().y) +
                             "x" + std::to_string(vb.dims().z) +
                             "): give --level K to compare a level decode with its source");
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

} // namespace

void addCodecCommands(CLI::App& app, GlobalOptions& global) {
    addEncode(app, global);
    addDecode(app, global);
    addCompare(app, global);
}

} // namespace volcl::cli
