// `volcl bench series`: motion-compensated against intra-only coding of time series per rate target, with
// per-frame PSNR, encode speed, single-frame decode time against an intra frame and playback rate (decode
// timings interleaved between the two codings, load average stated).
#include "apps/bench/BenchCommand.hpp"
#include "apps/bench/BenchPaths.hpp"
#include "apps/bench/GzipVolume.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/Timing.hpp"
#include "host/io/Series.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/predict/TranslatedSeries.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

namespace volcl::cli {

namespace {

namespace fs = std::filesystem;

struct SeriesBenchArgs {
    std::string data = defaultSharedDataDir(), filter, json, exportDir;
    std::vector<std::string> rates{"lossless", "psnr40", "psnr50", "psnr60", "maxerr1%"};
    std::size_t gop = 10, bFrames = 0, mriFrames = 10, mriCrop = 128;
    int runs = 3;
    bool globalShift = true;
};

struct NamedSeries {
    std::string name;
    TimeSeries series;
};

nlohmann::json jnum(double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json("inf");
}

std::vector<NamedSeries> loadSeries(const SeriesBenchArgs& a) {
    std::vector<NamedSeries> out;
    auto want = [&](const std::string& n) {
        return a.filter.empty() || n.find(a.filter) != std::string::npos;
    };
    const fs::path t = fs::path(a.data) / "timevarying";
    auto add = [&](const std::string& name, std::vector<std::string> inputs) {
        if (!want(name)) return;
        try {
            for (std::string& s : inputs)
                s = (t / s).string();
            TimeSeries ts = readSeriesInputs(inputs).series;
            ts.times.clear();
            out.push_back({name, std::move(ts)});
        } catch (const Error& e) {
            std::cerr << "volcl bench series: skipping " << name << ": " << e.what() << '\n';
        }
    };
    add("viscous-20", {"viscousfingers/*_density_*.vti"});
    if (want("mri-shift")) {
        try {
            const fs::path p =
                fs::path(a.data) / "regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz";
            const Volume mri = readGzipUInt8(p, {180, 216, 180});
            const std::size_t c = std::min<std::size_t>(a.mriCrop, 180);
            const Dims lo{(180 - c) / 2, (216 - c) / 2, (180 - c) / 2};
            // 0.7 / -0.4 / 0.3 voxels per frame: a sub-voxel drift no search grid hits exactly.
            out.push_back({"mri-shift", translatedSeries(mri.cropped(lo, {lo.x + c, lo.y + c, lo.z + c}),
                                                         a.mriFrames, {0.7, -0.4, 0.3})});
        } catch (const Error& e) {
            std::cerr << "volcl bench series: skipping mri-shift: " << e.what() << '\n';
        }
    }
    add("fmri", {"functional.nii.gz"});
    add("isabel-02-05",
        {"isabel/isabel_02.vti", "isabel/isabel_03.vti", "isabel/isabel_04.vti", "isabel/isabel_05.vti"});
    add("isabel-30-33",
        {"isabel/isabel_30.vti", "isabel/isabel_31.vti", "isabel/isabel_32.vti", "isabel/isabel_33.vti"});
    add("isabel-45-48",
        {"isabel/isabel_45.vti", "isabel/isabel_46.vti", "isabel/isabel_47.vti", "isabel/isabel_48.vti"});
    return out;
}

// The options of a rate name: lossless, psnrP, maxerrX% (X percent of the series' value range).
CodecOptions rateOptions(const std::string& rate, const TimeSeries& ts) {
    CodecOptions o;
    if (rate == "lossless") return o;
    if (rate.rfind("psnr", 0) == 0) {
        o.rate = RateMode::Psnr;
        o.target = std::stod(rate.substr(4));
        return o;
    }
    if (rate.rfind("maxerr", 0) == 0 && rate.back() == '%') {
        double lo = INFINITY, hi = -INFINITY;
        for (const Volume& v : ts.frames) {
            const VolumeStats s = v.stats(1);
            lo = std::min(lo, s.min);
            hi = std::max(hi, s.max);
        }
        o.rate = RateMode::MaxError;
        o.target = std::stod(rate.substr(6, rate.size() - 7)) / 100 * (hi - lo);
        return o;
    }
    throw UsageError("--rate must be lossless, psnrP or maxerrX% (got '" + rate + "')");
}

struct Coding {
    std::vector<std::byte> file;
    std::size_t bytes = 0;
    double bpv = 0, minPsnr = INFINITY, meanMse = 0, maxErr = 0, encodeMs = 0, playbackMs = 0, frameMs = 0;
    double playbackCpuMs = 0, frameCpuMs = 0;
    // Per run: whole series in order, one frame given its reference; wall and process CPU time.
    std::vector<double> playback, frame, playbackCpu, frameCpu;
    std::vector<double> framePsnr;    // per frame, decoded in order
    std::vector<FrameReport> reports; // per frame, what the encoder did
    std::size_t p = 0, b = 0;
    bool exact = true;
};

// Decodes every frame in order as a player does (each P frame from the frame before it, which it keeps);
// returns the milliseconds, and with `c` the accuracy of every frame against the input.
double playSeries(ComputeContext& cc, const VczReader& r, const TimeSeries& ts, Coding* c) {
    std::vector<std::optional<Volume>> frames(ts.frames.size());
    std::vector<const Volume*> known(ts.frames.size(), nullptr);
    Stopwatch pw;
    for (std::size_t f = 0; f < ts.frames.size(); ++f) {
        frames[f] = r.decodeFrame(cc, f, known);
        known[f] = &*frames[f];
        if (f > 0) { // a player keeps the latest frame
            known[f - 1] = nullptr;
            frames[f - 1].reset();
        }
        if (c) {
            const double p = psnr(ts.frames[f], *frames[f]);
            c->framePsnr.push_back(p);
            c->minPsnr = std::min(c->minPsnr, p);
            c->maxErr = std::max(c->maxErr, maxAbsError(ts.frames[f], *frames[f]));
            c->exact = c->exact && *frames[f] == ts.frames[f];
            const double e = rmse(ts.frames[f], *frames[f]);
            c->meanMse += e * e / double(ts.frames.size());
        }
    }
    return pw.milliseconds();
}

// Encodes (timed once: the encoder is the slow side and the rows are many) and checks every decoded frame.
Coding code(ComputeContext& cc, const TimeSeries& ts, const CodecOptions& o) {
    Coding c;
    Stopwatch sw;
    c.file = encodeSeries(cc, ts, o, &c.reports);
    c.encodeMs = sw.milliseconds();
    c.bytes = c.file.size();
    const double voxels = double(ts.frames[0].voxelCount() * ts.frames.size());
    c.bpv = double(c.bytes) * 8 / voxels;
    VczReader r(c.file, "bench.vcz");
    for (const VczFrame& f : r.header().frames) {
        c.p += f.type == FrameType::P;
        c.b += f.type == FrameType::B;
    }
    playSeries(cc, r, ts, &c);
    return c;
}

// One timed run of a coding: the series played in order, then one frame decoded given its reference (the
// last frame of the first group, a P frame with motion; an I frame in intra-only coding).
void timeRun(ComputeContext& cc, const TimeSeries& ts, std::size_t gop, Coding& c) {
    const VczReader r(c.file, "bench.vcz");
    const ProcessCpuStopwatch pc;
    c.playback.push_back(playSeries(cc, r, ts, nullptr));
    c.playbackCpu.push_back(pc.milliseconds());
    const std::size_t k = std::min(ts.frames.size(), gop) - 1;
    const Volume ref = r.decodeFrame(cc, k > 0 ? k - 1 : 0);
    std::vector<const Volume*> withRef(k + 1, nullptr);
    if (k > 0) withRef[k - 1] = &ref;
    const ProcessCpuStopwatch fc;
    Stopwatch fw;
    r.decodeFrame(cc, k, withRef);
    c.frame.push_back(fw.milliseconds());
    c.frameCpu.push_back(fc.milliseconds());
}

// Writes a series for peers that read raw arrays: <dir>/<name>.f32 (every frame as float32, x fastest, then
// y, z, frame) and <dir>/<name>.json (dims, frames, voxel type).
void exportSeries(const std::string& dir, const NamedSeries& s) {
    fs::create_directories(dir);
    const Dims d = s.series.frames[0].dims();
    std::vector<float> all;
    all.reserve(d.count() * s.series.frames.size());
    for (const Volume& v : s.series.frames) {
        const std::vector<float> f = v.toFloat();
        all.insert(all.end(), f.begin(), f.end());
    }
    AtomicFile raw((fs::path(dir) / (s.name + ".f32")).string());
    raw.write(std::string_view(reinterpret_cast<const char*>(all.data()), all.size() * sizeof(float)));
    raw.commit();
    const nlohmann::json j{{"series", s.name},
                           {"dims", {d.x, d.y, d.z}},
                           {"frames", s.series.frames.size()},
                           {"type", scalarTypeName(s.series.frames[0].type())}};
    AtomicFile meta((fs::path(dir) / (s.name + ".json")).string());
    meta.write(j.dump(1));
    meta.commit();
}

double loadAverage() {
    double l[1] = {0};
    return getloadavg(l, 1) == 1 ? l[0] : NAN;
}

nlohmann::json framePsnrs(const Coding& c) {
    nlohmann::json j = nlohmann::json::array();
    for (double p : c.framePsnr)
        j.push_back(jnum(p));
    return j;
}

nlohmann::json frameBytes(const Coding& c) {
    nlohmann::json j = nlohmann::json::array();
    for (const FrameReport& r : c.reports)
        j.push_back(r.bytes);
    return j;
}

// "I", "P" or "B" per frame; "I*" for a planned P/B frame coded as an I frame because that was smaller.
nlohmann::json frameTypes(const Coding& c) {
    nlohmann::json j = nlohmann::json::array();
    for (const FrameReport& r : c.reports)
        j.push_back(r.type == FrameType::P   ? "P"
                    : r.type == FrameType::B ? "B"
                    : r.intraFallback        ? "I*"
                                             : "I");
    return j;
}

void benchSeries(const SeriesBenchArgs& a, GlobalOptions& global) {
    ComputeContext cc(global.device);
    const std::vector<NamedSeries> all = loadSeries(a);
    if (all.empty()) throw UsageError("no series to benchmark (see --data and --dataset)");
    nlohmann::json rows = nlohmann::json::array();
    std::cerr << "volcl bench series: device " << cc.device().name << ", gop " << a.gop << ", b-frames "
              << a.bFrames << ", decode times median of " << a.runs << "\n";
    for (const NamedSeries& s : all) {
        if (!a.exportDir.empty()) exportSeries(a.exportDir, s);
        const Dims d = s.series.frames[0].dims();
        std::cerr << s.name << ": " << s.series.frames.size() << " frames of " << d.x << "x" << d.y << "x"
                  << d.z << " " << scalarTypeName(s.series.frames[0].type()) << '\n';
        for (const std::string& rate : a.rates) {
            CodecOptions o = rateOptions(rate, s.series);
            o.gop = a.gop;
            o.bFrames = a.bFrames;
            o.globalShift = a.globalShift;
            CodecOptions intraOnly = o;
            intraOnly.motion = MotionMode::None;
            Coding in = code(cc, s.series, intraOnly), mc = code(cc, s.series, o);
            // Decode timings interleaved run by run (intra, motion), so both see the same load.
            const double loadBefore = loadAverage();
            for (int run = 0; run < a.runs; ++run) {
                timeRun(cc, s.series, a.gop, in);
                timeRun(cc, s.series, a.gop, mc);
            }
            const double loadAfter = loadAverage();
            for (Coding* c : {&in, &mc}) {
                c->playbackMs = median(c->playback);
                c->frameMs = median(c->frame);
                c->playbackCpuMs = median(c->playbackCpu);
                c->frameCpuMs = median(c->frameCpu);
            }
            const double mb = double(s.series.frames[0].byteSize() * s.series.frames.size()) / 1e6;
            auto psnrOfMean = [&](const Coding& c) {
                double lo = INFINITY, hi = -INFINITY;
                for (const Volume& v : s.series.frames) {
                    const VolumeStats st = v.stats(1);
                    lo = std::min(lo, st.min);
                    hi = std::max(hi, st.max);
                }
                return c.meanMse > 0 ? 10 * std::log10((hi - lo) * (hi - lo) / c.meanMse) : INFINITY;
            };
            std::cerr << "  " << std::setw(9) << rate << ": intra " << formatFixed(in.bpv, 4)
                      << " bpv (min PSNR " << formatFixed(in.minPsnr, 2) << "), MC " << formatFixed(mc.bpv, 4)
                      << " bpv (min PSNR " << formatFixed(mc.minPsnr, 2) << ", " << mc.p << " P " << mc.b
                      << " B) = " << formatFixed(mc.bpv / in.bpv, 3) << "x; encode "
                      << formatFixed(mb / in.encodeMs * 1e3, 1) << " / "
                      << formatFixed(mb / mc.encodeMs * 1e3, 1) << " MB/s; frame "
                      << formatFixed(in.frameMs, 1) << " / " << formatFixed(mc.frameMs, 1) << " ms (P/I "
                      << formatFixed(mc.frameMs / in.frameMs, 2) << "x); playback "
                      << formatFixed(1e3 * double(s.series.frames.size()) / in.playbackMs, 1) << " / "
                      << formatFixed(1e3 * double(s.series.frames.size()) / mc.playbackMs, 1)
                      << " fps; CPU per frame " << formatFixed(in.frameCpuMs, 1) << " / "
                      << formatFixed(mc.frameCpuMs, 1) << " ms (P/I "
                      << formatFixed(mc.frameCpuMs / in.frameCpuMs, 2) << "x), playing "
                      << formatFixed(in.playbackCpuMs / double(s.series.frames.size()), 1) << " / "
                      << formatFixed(mc.playbackCpuMs / double(s.series.frames.size()), 1) << " ms; load "
                      << formatFixed(loadBefore, 1) << " -> " << formatFixed(loadAfter, 1) << "\n";
            for (const auto& [mode, c] : {std::pair<const char*, const Coding&>{"intra", in}, {"mc", mc}})
                rows.push_back(
                    {{"series", s.name},
                     {"frames", s.series.frames.size()},
                     {"dims", {d.x, d.y, d.z}},
                     {"rate", rate},
                     {"mode", mode},
                     {"bytes", c.bytes},
                     {"bits_per_voxel", c.bpv},
                     {"min_frame_psnr_db", jnum(c.minPsnr)},
                     {"series_psnr_db", jnum(psnrOfMean(c))},
                     {"max_error", c.maxErr},
                     {"exact", c.exact},
                     {"p_frames", c.p},
                     {"b_frames", c.b},
                     {"encode_ms", c.encodeMs},
                     {"encode_mb_s", mb / c.encodeMs * 1e3},
                     {"frame_decode_ms", c.frameMs},
                     {"frame_decode_over_intra", c.frameMs / in.frameMs},
                     {"playback_ms_runs", c.playback},
                     {"playback_cpu_ms_runs", c.playbackCpu},
                     {"frame_decode_cpu_ms_runs", c.frameCpu},
                     {"frame_decode_cpu_ms", c.frameCpuMs},
                     {"frame_decode_cpu_over_intra", c.frameCpuMs / in.frameCpuMs},
                     {"playback_cpu_ms_per_frame", c.playbackCpuMs / double(s.series.frames.size())},
                     {"frame_decode_ms_runs", c.frame},
                     {"load_before", jnum(loadBefore)},
                     {"load_after", jnum(loadAfter)},
                     {"frame_psnr_db", framePsnrs(c)},
                     {"frame_bytes", frameBytes(c)},
                     {"frame_types", frameTypes(c)},
                     {"playback_fps", 1e3 * double(s.series.frames.size()) / c.playbackMs}});
        }
    }
    const nlohmann::json j{{"device", cc.device().name}, {"gop", a.gop},   {"global_shift", a.globalShift},
                           {"b_frames", a.bFrames},      {"runs", a.runs}, {"rows", rows}};
    if (a.json.empty()) {
        std::cout << j.dump(1) << '\n';
    } else {
        AtomicFile f(a.json);
        f.write(j.dump(1));
        f.commit();
    }
}

} // namespace

void addSeriesBench(CLI::App& bench, GlobalOptions& global) {
    auto* b =
        bench.add_subcommand("series", "Time series: motion-compensated against intra-only coding per rate "
                                       "target (bits/voxel, PSNR, encode speed, frame decode, playback)");
    auto a = std::make_shared<SeriesBenchArgs>();
    b->add_option("--data", a->data, "Shared data directory")->capture_default_str();
    b->add_option("--dataset", a->filter,
                  "Only series whose name contains this text (viscous, mri, fmri, isabel)");
    b->add_option("--rate", a->rates,
                  "Rate targets: lossless, psnrP, maxerrX% (default lossless psnr40 psnr50 "
                  "psnr60 maxerr1%)");
    b->add_option("--gop", a->gop, "Frames per group")->capture_default_str();
    b->add_option("--b-frames", a->bFrames, "B frames between anchors")->capture_default_str();
    b->add_option("--mri-frames", a->mriFrames, "Frames of the shifted MRI series")->capture_default_str();
    b->add_option("--mri-crop", a->mriCrop, "Edge of the shifted MRI cube")->capture_default_str();
    b->add_option("--runs", a->runs, "Timed decode runs (median)")->capture_default_str();
    b->add_option("--json", a->json, "JSON output file (default: stdout)");
    b->add_flag("!--no-global-shift", a->globalShift,
                "P frames use block motion alone (no global sub-voxel translation of the reference)");
    b->add_option("--export", a->exportDir,
                  "Also write each series as raw float32 (<name>.f32 + <name>.json) for peer codecs");
    b->callback([a, &global] {
        if (a->runs < 1) throw UsageError("--runs must be at least 1");
        benchSeries(*a, global);
    });
}

} // namespace volcl::cli
