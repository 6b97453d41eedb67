// `volcl bench codec`: our codec's ratio, PSNR and speed (warm in process, and cold: a fresh `volcl encode` /
// `volcl decode` per run) against zfp, zstd and xz on real volumes.
#include "apps/bench/BenchCommand.hpp"

#include "apps/bench/BenchOutput.hpp"
#include "apps/bench/BenchPaths.hpp"
#include "apps/bench/CodecPeers.hpp"
#include "apps/bench/GzipVolume.hpp"
#include "apps/cli/CodecReport.hpp"
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/Timing.hpp"
#include "host/io/VolumeIo.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/Metrics.hpp"
#include "wavelet/container/LodStatistics.hpp"

#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <span>
#include <sstream>

namespace volcl::cli {

namespace {

namespace fs = std::filesystem;

struct BenchData {
    std::string name;
    Volume volume;
    bool realScan = false; ///< CT/MRI: the lossless ratio goal against xz -9 applies
    fs::path source;       ///< the file `volcl encode` reads it from (empty: the benchmark writes one)
};

std::vector<BenchData> loadBenchData(const fs::path& shared, const std::string& filter, bool withLarge) {
    std::vector<BenchData> out;
    auto want = [&](const std::string& n) { return filter.empty() || n.find(filter) != std::string::npos; };
    auto add = [&](const std::string& name, const std::function<Volume()>& load, bool scan,
                   const fs::path& source = {}) {
        if (!want(name)) return;
        try {
            out.push_back({name, load(), scan, source});
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
                return readGzipUInt8(r / "t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz",
                                     {180, 216, 180});
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
            "ch2better-mri", [&] { return readVolume(mri); }, true, mri);
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

// Wall milliseconds of one run of `exe` with `args` (stdout and stderr to /dev/null); throws when it cannot
// start or does not exit with 0.
double runMilliseconds(const std::string& exe, const std::vector<std::string>& args) {
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
    if (started != 0) throw Error("bench codec: cannot start " + exe);
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    const double ms = sw.milliseconds();
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
        throw Error("bench codec: `" + exe + " " + args.front() + " ...` failed (status " +
                    std::to_string(status) + ")");
    return ms;
}

// One run of this executable (a fresh `volcl` process).
double runSelfMilliseconds(const std::vector<std::string>& args) {
    static const std::string exe = fs::read_symlink("/proc/self/exe").string();
    return runMilliseconds(exe, args);
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

struct BenchArgs {
    std::string data = defaultSharedDataDir(), filter, csv, json;
    int runs = 3, levels = 4;
    std::size_t brick = 64;
    bool noXz = false, large = false;
    bool cold = true;           ///< lossless rows also time a fresh CLI process per run
    std::string zfpCli = "zfp"; ///< zfp's command-line tool for the one-shot rows (empty: none)
    std::vector<double> psnrs{30, 40, 50, 60, 70};
    std::vector<std::string> modes; ///< only rows whose mode contains one of these (empty: all)
    std::string coder;              ///< only this entropy coder's rows (empty: both)
    bool wants(const std::string& mode) const {
        return modes.empty() || std::any_of(modes.begin(), modes.end(), [&](const std::string& m) {
                   return mode.find(m) != std::string::npos;
               });
    }
};

// One data set under measurement: what each of its rows needs, and where the rows go.
struct DatasetRun {
    const BenchArgs& args;
    const GlobalOptions& global;
    ComputeContext& cc;
    const BenchData& data;
    const ColdFiles* cold; ///< the cold runs' files; null when cold runs are off
    std::vector<BenchRow>& rows;
    double megabytes() const { return double(data.volume.byteSize()) / 1e6; }
    double voxels() const { return double(data.volume.voxelCount()); }
};

// Median milliseconds of our encode and decode; with cold runs also of a fresh CLI process each.
struct OurTimes {
    double encMs = 0, decMs = 0, encColdMs = 0, decColdMs = 0, statsMs = 0;
};

// The arguments of a quiet `volcl` run on the benchmark's device: [--device D] -q `tail`.
std::vector<std::string> quietCli(const DatasetRun& run, std::vector<std::string> tail) {
    std::vector<std::string> all;
    if (!run.global.device.empty()) all = {"--device", run.global.device};
    all.push_back("-q");
    all.insert(all.end(), tail.begin(), tail.end());
    return all;
}

// Cold and warm runs interleaved, so both see the same load; the warm-up run of each side (kernel builds,
// the on-disk program cache) is not timed. `bytes` is what `warmEncode` last wrote.
OurTimes timeColdAndWarm(const DatasetRun& run, const std::string& coder, const std::vector<std::byte>& bytes,
                         const std::function<void()>& warmEncode, const std::function<void()>& warmDecode) {
    const BenchArgs& a = run.args;
    auto with = [&](std::vector<std::string> tail) { return quietCli(run, std::move(tail)); };
    const std::vector<std::string> enc =
        with({"encode", run.cold->volume.string(), "-o", run.cold->vcz.string(), "--lossless", "--entropy",
              coder, "--levels", std::to_string(a.levels), "--brick", std::to_string(a.brick)});
    const std::vector<std::string> decArgs =
        with({"decode", run.cold->vcz.string(), "-o", run.cold->decoded.string()});
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
        (void)addLodStatistics(run.cc, bytes, std::span<const Volume>(&run.data.volume, 1), run.data.name);
        ws.push_back(sw.milliseconds());
        ce.push_back(runSelfMilliseconds(enc));
        sw.restart();
        warmDecode();
        wd.push_back(sw.milliseconds());
        cd.push_back(runSelfMilliseconds(decArgs));
    }
    OurTimes t;
    t.encMs = median(we);
    t.statsMs = median(ws);
    t.decMs = median(wd);
    t.encColdMs = median(ce);
    t.decColdMs = median(cd);
    return t;
}

void printOurRow(const BenchRow& r, const std::string& mode, const OurTimes& t) {
    std::cerr << "  " << r.codec << " " << mode << ": ratio " << formatFixed(r.ratio, 2) << " bpv "
              << formatFixed(r.bpv, 3) << " PSNR " << formatFixed(r.psnr, 2) << " maxerr " << r.maxError
              << " enc " << formatFixed(r.encodeMBs, 1) << " MB/s dec " << formatFixed(r.decodeMBs, 1)
              << " MB/s\n";
    if (t.encColdMs > 0)
        std::cerr << "    cold (a fresh volcl process per run, file read and write included): encode "
                  << formatFixed(t.encColdMs, 1) << " ms = " << formatFixed(r.encodeColdMBs, 1)
                  << " MB/s against warm " << formatFixed(t.encMs + t.statsMs, 1) << " ms = encode "
                  << formatFixed(t.encMs, 1) << " + level-of-detail statistics " << formatFixed(t.statsMs, 1)
                  << " (cold/warm " << formatFixed(t.encColdMs / (t.encMs + t.statsMs), 2) << "), decode "
                  << formatFixed(t.decColdMs, 1) << " ms = " << formatFixed(r.decodeColdMBs, 1)
                  << " MB/s against warm " << formatFixed(t.decMs, 1) << " ms (cold/warm "
                  << formatFixed(t.decColdMs / t.decMs, 2) << ")\n";
}

// Our codec in `mode` with options `o` (the bench's levels and brick): one row, unless --mode or --coder
// leaves it out.
void benchOurs(const DatasetRun& run, const std::string& mode, CodecOptions o) {
    const BenchArgs& a = run.args;
    const Volume& v = run.data.volume;
    const std::string coder(entropyName(o.entropy));
    if (!a.wants(mode) || (!a.coder.empty() && a.coder != coder)) return;
    o.levels = a.levels;
    o.brick = {a.brick, a.brick, a.brick};
    EncodeReport rep;
    auto bytes = encodeVolume(run.cc, v, o, &rep);
    // Time a fixed-step encode for lossy targets: the step search is a one-off cost of the target,
    // and so is the reconstruction that measures the error of a step (the bounded modes keep it: it
    // holds the bound).
    CodecOptions timed = o;
    if (o.rate != RateMode::Lossless && !isBoundedRate(o.rate)) {
        timed.step = rep.step;
        timed.measureError = false;
    }
    const std::size_t searchTrials = static_cast<std::size_t>(rep.profile.trials);
    Volume out;
    CodecProfile dec;
    const VczReader reader(bytes, run.data.name);
    DecodeOptions dopt;
    dopt.profile = &dec;
    auto warmEncode = [&] { bytes = encodeVolume(run.cc, v, timed, &rep); };
    auto warmDecode = [&] {
        dec = {};
        out = reader.decode(run.cc, dopt);
    };
    OurTimes t;
    if (run.cold && o.rate == RateMode::Lossless) {
        t = timeColdAndWarm(run, coder, bytes, warmEncode, warmDecode);
    } else {
        t.encMs = medianMilliseconds(a.runs, warmEncode);
        t.decMs = medianMilliseconds(a.runs, warmDecode);
    }
    const double mb = run.megabytes();
    BenchRow r{run.data.name, std::string("volcl-") + coder, mode};
    if (t.encColdMs > 0) {
        r.encodeColdMBs = mb / (t.encColdMs / 1e3);
        r.decodeColdMBs = mb / (t.decColdMs / 1e3);
    }
    r.ratio = double(v.byteSize()) / double(bytes.size());
    r.bpv = double(bytes.size()) * 8 / run.voxels();
    r.psnr = psnr(v, out);
    r.maxError = maxAbsError(v, out);
    r.encodeMBs = mb / (t.encMs / 1e3);
    r.decodeMBs = mb / (t.decMs / 1e3);
    if (o.rate == RateMode::Lossless && !(out == v))
        throw Error(run.data.name + ": lossless round trip is not exact");
    run.rows.push_back(r);
    printOurRow(r, mode, t);
    printProfile("enc", rep.profile, searchTrials);
    printProfile("dec", dec, 0);
}

// A zfp row of `mode` from one run: PSNR of `forPsnr` and max error of `forMaxError` (its decode, as float
// or in the volume's type) against the volume.
BenchRow zfpRow(const DatasetRun& run, const std::string& mode, const ZfpResult& z, const Volume& forPsnr,
                const Volume& forMaxError) {
    const Volume& v = run.data.volume;
    BenchRow r{run.data.name, "zfp", mode};
    r.ratio = double(v.byteSize()) / double(z.bytes);
    r.bpv = double(z.bytes) * 8 / run.voxels();
    r.psnr = psnr(v, forPsnr);
    r.maxError = maxAbsError(v, forMaxError);
    r.encodeMBs = run.megabytes() / (z.encodeMs / 1e3);
    r.decodeMBs = run.megabytes() / (z.decodeMs / 1e3);
    return r;
}

void benchZfpReversible(const DatasetRun& run) {
    const Volume& v = run.data.volume;
    const ZfpResult z = runZfp(v, std::nullopt, run.args.runs);
    const BenchRow r = zfpRow(run, "lossless", z, z.decoded.convertedTo(v.type()), z.decoded);
    run.rows.push_back(r);
    std::cerr << "  zfp reversible: ratio " << formatFixed(r.ratio, 2) << " enc "
              << formatFixed(r.encodeMBs, 1) << " dec " << formatFixed(r.decodeMBs, 1) << '\n';
}

void benchZstd(const DatasetRun& run, int level) {
    const Volume& v = run.data.volume;
    double ms = 0, dms = 0;
    const std::size_t bytes = zstdSize(v, level, ms, dms, run.args.runs);
    BenchRow r{run.data.name, "zstd-" + std::to_string(level), "lossless"};
    r.ratio = double(v.byteSize()) / double(bytes);
    r.bpv = double(bytes) * 8 / run.voxels();
    r.psnr = INFINITY;
    r.encodeMBs = run.megabytes() / (ms / 1e3);
    r.decodeMBs = run.megabytes() / (dms / 1e3);
    run.rows.push_back(r);
}

void benchXz(const DatasetRun& run, const fs::path& tmp) {
    const Volume& v = run.data.volume;
    double ms = 0;
    const std::size_t bytes = xzSize(v, tmp, ms);
    if (bytes == 0) return;
    BenchRow r{run.data.name, "xz-9", "lossless"};
    r.ratio = double(v.byteSize()) / double(bytes);
    r.bpv = double(bytes) * 8 / run.voxels();
    r.psnr = INFINITY;
    r.encodeMBs = run.megabytes() / (ms / 1e3);
    run.rows.push_back(r);
    std::cerr << "  xz -9: ratio " << formatFixed(r.ratio, 2) << '\n';
}

// Rate-distortion at equal PSNR: ours (target PSNR) against zfp tuned to the same PSNR.
void benchAtPsnr(const DatasetRun& run, double p) {
    const Volume& v = run.data.volume;
    CodecOptions lo;
    lo.rate = RateMode::Psnr;
    lo.target = p;
    benchOurs(run, "psnr" + formatFixed(p, 0), lo);
    const ZfpResult z = zfpAtPsnr(v, p, run.args.runs);
    const bool integer = !isFloatType(v.type());
    const Volume zd = integer ? z.decoded.convertedTo(v.type()) : z.decoded;
    const BenchRow r = zfpRow(run, "psnr" + formatFixed(p, 0), z, zd, zd);
    run.rows.push_back(r);
    std::cerr << "  zfp psnr" << p << ": bpv " << formatFixed(r.bpv, 3) << " PSNR " << formatFixed(r.psnr, 2)
              << '\n';
}

// The absolute path of `program` found on PATH (or `program` itself when it holds a slash), empty when absent.
std::string findProgram(const std::string& program) {
    if (program.empty()) return {};
    if (program.find('/') != std::string::npos) return access(program.c_str(), X_OK) == 0 ? program : "";
    const char* path = std::getenv("PATH");
    std::istringstream dirs(path ? path : "");
    for (std::string dir; std::getline(dirs, dir, ':');) {
        const fs::path candidate = fs::path(dir.empty() ? "." : dir) / program;
        if (access(candidate.c_str(), X_OK) == 0) return candidate.string();
    }
    return {};
}

// A user's one-shot commands at equal PSNR, each a fresh process, interleaved run by run and timed as wall
// time (file read and write included): `volcl encode SOURCE -o F.vcz --psnr P` (default options, so the
// level-of-detail statistics and the lossless comparison included) and `volcl decode F.vcz -o F.raw`,
// against zfp's command-line tool compressing and decompressing the voxels as a raw float32 file at the
// largest accuracy tolerance that reaches P (found once with libzfp, outside the timing; zfp has no
// 8/16-bit mode). MB/s count the volume's own bytes for both. PSNR of each from its decoded file, zfp's
// rounded to the voxel type as in the psnr rows.
void benchOneShot(const DatasetRun& run, double p, const fs::path& tmp) {
    const std::string zfp = findProgram(run.args.zfpCli);
    if (!run.cold) return;
    if (zfp.empty()) {
        std::cerr << "  oneshot psnr" << p << ": zfp's command-line tool (" << run.args.zfpCli
                  << ") is absent (apt-get install zfp): skipping\n";
        return;
    }
    const Volume& v = run.data.volume;
    const Dims d = v.dims();
    const std::string stem = (tmp / ("volcl-bench-oneshot-" + std::to_string(getpid()))).string();
    const std::string vcz = stem + ".vcz", dec = stem + "-decoded.raw", raw = stem + "-f32.raw",
                      zfpFile = stem + ".zfp", zdec = stem + "-zfp.raw";
    struct Cleanup {
        std::vector<std::string> files;
        ~Cleanup() {
            std::error_code ec;
            for (const std::string& f : files)
                fs::remove(f, ec);
        }
    } cleanup{{vcz, dec, raw, zfpFile, zdec}};
    {
        const std::vector<float> f = v.toFloat();
        std::ofstream out(raw, std::ios::binary);
        out.write(reinterpret_cast<const char*>(f.data()),
                  static_cast<std::streamsize>(f.size() * sizeof(float)));
        if (!out) throw Error("bench codec: cannot write " + raw);
    }
    const double tolerance = zfpAtPsnr(v, p, 0).tolerance;
    const std::string source = run.data.source.empty() ? run.cold->volume.string() : run.data.source.string();
    auto ours = [&](std::vector<std::string> tail) { return quietCli(run, std::move(tail)); };
    const std::vector<std::string> enc = ours({"encode", source, "-o", vcz, "--psnr", formatNumber(p)});
    // The same without the level-of-detail statistics (a renderer's, not the codec's), to show their share.
    const std::string vczNoStats = stem + "-no-lod-stats.vcz";
    cleanup.files.push_back(vczNoStats);
    const std::vector<std::string> encNoStats =
        ours({"encode", source, "-o", vczNoStats, "--psnr", formatNumber(p), "--no-lod-stats"});
    const std::vector<std::string> decArgs = ours({"decode", vcz, "-o", dec});
    const std::vector<std::string> dims = {"-f",
                                           "-3",
                                           std::to_string(d.x),
                                           std::to_string(d.y),
                                           std::to_string(d.z),
                                           "-a",
                                           formatNumber(tolerance)};
    std::vector<std::string> zenc = {"-q", "-i", raw, "-z", zfpFile},
                             zdecArgs = {"-q", "-z", zfpFile, "-o", zdec};
    zenc.insert(zenc.end(), dims.begin(), dims.end());
    zdecArgs.insert(zdecArgs.end(), dims.begin(), dims.end());
    const std::string loadBefore = loadAverage();
    // Warm-up of each (page cache, the program cache of the kernels), not timed.
    runSelfMilliseconds(enc);
    runSelfMilliseconds(decArgs);
    runMilliseconds(zfp, zenc);
    runMilliseconds(zfp, zdecArgs);
    std::vector<double> oe, on, od, ze, zd;
    for (int i = 0; i < run.args.runs; ++i) {
        on.push_back(runSelfMilliseconds(encNoStats));
        oe.push_back(runSelfMilliseconds(enc));
        ze.push_back(runMilliseconds(zfp, zenc));
        od.push_back(runSelfMilliseconds(decArgs));
        zd.push_back(runMilliseconds(zfp, zdecArgs));
    }
    const std::string loadAfter = loadAverage();
    const double mb = run.megabytes();
    auto rawOf = [&](ScalarType t) {
        ReadOptions o;
        o.dims = d;
        o.type = t;
        return o;
    };
    BenchRow r{run.data.name, "volcl-oneshot", "psnr" + formatFixed(p, 0)};
    BenchRow z{run.data.name, "zfp-cli", r.mode};
    r.bpv = double(fs::file_size(vcz)) * 8 / run.voxels();
    z.bpv = double(fs::file_size(zfpFile)) * 8 / run.voxels();
    r.ratio = double(v.byteSize()) / double(fs::file_size(vcz));
    z.ratio = double(v.byteSize()) / double(fs::file_size(zfpFile));
    r.psnr = psnr(v, readVolume(dec, rawOf(v.type())));
    z.psnr = psnr(v, readVolume(zdec, rawOf(ScalarType::Float32)).convertedTo(v.type()));
    r.encodeColdMBs = mb / (median(oe) / 1e3);
    r.decodeColdMBs = mb / (median(od) / 1e3);
    z.encodeColdMBs = mb / (median(ze) / 1e3);
    z.decodeColdMBs = mb / (median(zd) / 1e3);
    BenchRow n = r;
    n.codec = "volcl-oneshot-no-lod-stats";
    n.encodeColdMBs = mb / (median(on) / 1e3);
    n.decodeColdMBs = 0;
    n.bpv = double(fs::file_size(vczNoStats)) * 8 / run.voxels();
    n.ratio = double(v.byteSize()) / double(fs::file_size(vczNoStats));
    run.rows.push_back(r);
    run.rows.push_back(n);
    run.rows.push_back(z);
    std::cerr << "  oneshot psnr" << p << " (fresh processes, medians of " << run.args.runs
              << " interleaved runs, load " << loadBefore << " -> " << loadAfter << "): volcl encode "
              << formatFixed(median(oe), 1) << " ms = " << formatFixed(r.encodeColdMBs, 1)
              << " MB/s (--no-lod-stats " << formatFixed(median(on), 1)
              << " ms = " << formatFixed(n.encodeColdMBs, 1) << " MB/s), decode "
              << formatFixed(median(od), 1) << " ms = " << formatFixed(r.decodeColdMBs, 1) << " MB/s, "
              << formatFixed(r.bpv, 3) << " bpv, PSNR " << formatFixed(r.psnr, 2) << " dB; zfp -a "
              << formatNumber(tolerance) << " encode " << formatFixed(median(ze), 1)
              << " ms = " << formatFixed(z.encodeColdMBs, 1) << " MB/s, decode " << formatFixed(median(zd), 1)
              << " ms = " << formatFixed(z.decodeColdMBs, 1) << " MB/s, " << formatFixed(z.bpv, 3)
              << " bpv, PSNR " << formatFixed(z.psnr, 2) << " dB; volcl/zfp speed: encode "
              << formatFixed(r.encodeColdMBs / z.encodeColdMBs, 2) << "x, decode "
              << formatFixed(r.decodeColdMBs / z.decodeColdMBs, 2) << "x\n";
}

// Transform only: one level of 3D 5/3 on the codec's bricks, against the copy kernel on the same
// bytes; the brick-resident kernel (what the codec runs on CPUs) and the streaming passes (the
// general path) measured in the same run. Appends one JSON object per kernel to `transforms`.
void benchTransform(const DatasetRun& run, nlohmann::json& transforms) {
    const BenchArgs& a = run.args;
    const Volume& v = run.data.volume;
    ComputeContext& cc = run.cc;
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
        const char* kernel = t.pathFor(batch) == LiftingPath::Streaming ? "streaming" : "brick-resident";
        t.forward(cc, batch, 1); // warm-up: builds and specialises the kernels
        std::vector<double> ms;
        for (int i = 0; i < std::max(3, a.runs); ++i)
            ms.push_back(t.forward(cc, batch, 1));
        const double med = median(ms);
        // Bytes of three streaming passes (int32 read + write each): the brick-resident kernel moves
        // less, so its fraction is of the work, not of its own traffic.
        const double gbs = voxels * 3 * 8 / (med * 1e6);
        transforms.push_back({{"dataset", run.data.name},
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

// Every row of one data set, in the order of the table: ours lossless, the lossless peers, the PSNR targets
// against zfp, the bit-rate and max-error targets, then the transform alone.
// The relative bounds scientists set: ours at R x the finite value range beside zfp's fixed accuracy at
// that tolerance (zfp's absolute bound), and ours at a point-wise relative R (zfp has no such mode).
void benchRelative(const DatasetRun& run) {
    const Volume& v = run.data.volume;
    const VolumeStats st = v.stats(1);
    for (double r : {1e-3, 1e-4}) {
        const std::string mode = "relerr" + formatNumber(r);
        if (!run.args.wants(mode)) continue;
        CodecOptions o;
        o.rate = RateMode::RelError;
        o.target = r;
        benchOurs(run, mode, o);
        const ZfpResult z = runZfp(v, r * (st.max - st.min), run.args.runs);
        const Volume typed = z.decoded.convertedTo(v.type());
        run.rows.push_back(zfpRow(run, mode, z, typed, typed));
    }
    for (double r : {1e-2, 1e-3}) {
        CodecOptions o;
        o.rate = RateMode::PwRelError;
        o.target = r;
        benchOurs(run, "pwrel" + formatNumber(r), o);
    }
}

void benchDataset(const DatasetRun& run, const fs::path& tmp, nlohmann::json& transforms) {
    const BenchArgs& a = run.args;
    const Volume& v = run.data.volume;
    std::cerr << "== " << run.data.name << " " << v.dims().x << "x" << v.dims().y << "x" << v.dims().z << " "
              << scalarTypeName(v.type()) << '\n';
    const bool integer = !isFloatType(v.type());
    CodecOptions o;
    o.rate = RateMode::Lossless;
    for (EntropyMode m : {EntropyMode::Dense, EntropyMode::Fast}) {
        o.entropy = m;
        benchOurs(run, "lossless", o);
    }
    const bool lossless = a.wants("lossless");
    if (integer && lossless) benchZfpReversible(run);
    if (lossless)
        for (int level : {3, 19})
            benchZstd(run, level);
    if (!a.noXz && lossless) benchXz(run, tmp);
    for (double p : a.psnrs)
        if (a.wants("psnr" + formatFixed(p, 0))) benchAtPsnr(run, p);
    // One-shot commands against zfp's tool only when asked for (--mode oneshot): fresh processes are slow.
    for (double p : a.psnrs)
        if (!a.modes.empty() && a.wants("oneshot-psnr" + formatFixed(p, 0))) benchOneShot(run, p, tmp);
    // The speed goal at 1-2 bits/voxel, with both entropy coders.
    for (EntropyMode m : {EntropyMode::Dense, EntropyMode::Fast})
        for (double bpv : {1.0, 2.0}) {
            CodecOptions lo;
            lo.rate = RateMode::Bpv;
            lo.target = bpv;
            lo.entropy = m;
            benchOurs(run, "bpv" + formatFixed(bpv, 0), lo);
        }
    const VolumeStats st = v.stats(1);
    CodecOptions lo;
    lo.rate = RateMode::MaxError;
    lo.target = std::max((st.max - st.min) * 0.005, integer ? 1.0 : 1e-6);
    benchOurs(run, "maxerr0.5%", lo);
    benchRelative(run);
    if (a.wants("transform")) benchTransform(run, transforms);
}

// The rows as CSV (to --csv, else stdout) and, with --json, as JSON with the transform measurements.
void writeCodecTables(const BenchArgs& a, const ComputeContext& cc, const std::vector<BenchRow>& rows,
                      const nlohmann::json& transforms) {
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
    writeOutput(a.csv, csv.str());
    if (!a.json.empty()) writeOutput(a.json, j.dump(1));
}

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
        std::optional<ColdFiles> cold;
        if (a.cold) {
            cold.emplace(tmp);
            writeVolumeFile(ds.volume, cold->volume);
        }
        benchDataset({a, global, cc, ds, cold ? &*cold : nullptr, rows}, tmp, transforms);
    }
    writeCodecTables(a, cc, rows, transforms);
}

} // namespace

void addCodecBench(CLI::App& bench, GlobalOptions& global) {
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
    b->add_option(
         "--zfp-cli", a->zfpCli,
         "zfp's command-line tool for the one-shot rows (fresh `volcl encode/decode` processes against "
         "it at equal PSNR; needs --cold)")
        ->capture_default_str();
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
