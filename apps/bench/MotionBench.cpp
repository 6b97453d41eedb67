// `volcl bench motion`: block-search time against block size, radius and method, with the prediction error.
#include "apps/bench/BenchCommand.hpp"
#include "apps/bench/BenchOutput.hpp"
#include "apps/bench/BenchPaths.hpp"
#include "apps/bench/GzipVolume.hpp"
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/Timing.hpp"
#include "host/io/Series.hpp"
#include "host/io/VolumeIo.hpp"
#include "wavelet/predict/Compensation.hpp"
#include "wavelet/predict/MotionSearch.hpp"
#include "wavelet/predict/MotionVectorCoding.hpp"
#include "wavelet/predict/TranslatedSeries.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace volcl::cli {

namespace {

namespace fs = std::filesystem;

struct MotionBenchArgs {
    std::string data = defaultSharedDataDir(), filter, csv, json;
    std::vector<std::size_t> blocks{4, 8, 16};
    std::vector<int> radii{1, 2, 4, 8};
    int runs = 3;
    std::size_t mriCrop = 128;
    bool reference = true;
};

// One pair of frames to predict: `current` from `reference`.
struct MotionPair {
    std::string name;
    Volume current, reference;
};

std::vector<MotionPair> loadPairs(const MotionBenchArgs& a) {
    std::vector<MotionPair> out;
    auto want = [&](const std::string& n) {
        return a.filter.empty() || n.find(a.filter) != std::string::npos;
    };
    const fs::path t = fs::path(a.data) / "timevarying";
    auto addSeries = [&](const std::string& name, const std::string& glob, std::size_t from) {
        if (!want(name)) return;
        try {
            const SeriesInput s = readSeriesInputs(std::vector<std::string>{(t / glob).string()});
            if (s.series.frames.size() <= from + 1) throw DataError("too few frames");
            out.push_back({name, s.series.frames[from + 1], s.series.frames[from]});
        } catch (const Error& e) {
            std::cerr << "volcl bench motion: skipping " << name << ": " << e.what() << '\n';
        }
    };
    addSeries("viscous-10-11", "viscousfingers/*_density_*.vti", 9);
    addSeries("isabel-03-04", "isabel/isabel_0*.vti", 1);
    if (want("mri-shift")) {
        try {
            const Volume mri = readGzipUInt8(
                fs::path(a.data) / "regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz",
                {180, 216, 180});
            const std::size_t c = std::min<std::size_t>(a.mriCrop, 180);
            const Dims lo{(180 - c) / 2, (216 - c) / 2, (180 - c) / 2};
            const Volume crop = mri.cropped(lo, {lo.x + c, lo.y + c, lo.z + c});
            // 0.7 / -0.4 / 0.3 voxels per frame: a sub-voxel drift no search grid hits exactly.
            const TimeSeries ts = translatedSeries(crop, 2, {0.7, -0.4, 0.3});
            out.push_back({"mri-shift", ts.frames[1], ts.frames[0]});
        } catch (const Error& e) {
            std::cerr << "volcl bench motion: skipping mri-shift: " << e.what() << '\n';
        }
    }
    return out;
}

double psnrOver(const Volume& truth, const Volume& pred, double& rmse) {
    const VolumeStats st = truth.stats(1);
    double e = 0;
    for (std::size_t i = 0; i < truth.voxelCount(); ++i) {
        const double d = truth.valueAt(i) - pred.valueAt(i);
        e += d * d;
    }
    rmse = std::sqrt(e / double(truth.voxelCount()));
    return rmse > 0 ? 20 * std::log10((st.max - st.min) / rmse) : INFINITY;
}

nlohmann::json jnum(double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json("inf");
}

void benchMotion(const MotionBenchArgs& a, GlobalOptions& global) {
    ComputeContext cc(global.device);
    std::vector<MotionPair> pairs = loadPairs(a);
    if (pairs.empty()) throw UsageError("no data set to benchmark (see --data and --dataset)");
    std::cerr << "volcl bench motion: device " << cc.device().name << ", kernel time = median of " << a.runs
              << " runs after a warm-up (builds excluded); reference C++ single-threaded\n";
    MotionCompensator comp(cc);
    nlohmann::json rows = nlohmann::json::array(), speed = nlohmann::json::array();
    std::ostringstream csv;
    csv << "dataset,block,radius,method,search_ms,prediction_psnr_db,residual_rmse,zero_motion_psnr_db,"
           "inter_blocks,motion_bytes,bits_per_voxel_motion\n";
    for (const MotionPair& p : pairs) {
        const Dims d = p.current.dims();
        double zeroRmse = 0;
        const double zeroPsnr = psnrOver(p.current, p.reference, zeroRmse);
        std::cerr << "== " << p.name << " " << d.x << "x" << d.y << "x" << d.z << ": no motion PSNR "
                  << formatFixed(zeroPsnr, 2) << " dB\n";
        for (std::size_t B : a.blocks)
            for (int R : a.radii)
                for (MotionSearchMethod m : {MotionSearchMethod::Full, MotionSearchMethod::Hierarchical}) {
                    const MotionSearchOptions o{B, R, m, MotionCost::Ssd, true};
                    if (m == MotionSearchMethod::Hierarchical && hierarchyLevels(o) == 0) continue; // = full
                    MotionEstimator est(cc, o);
                    const int levels = m == MotionSearchMethod::Hierarchical ? hierarchyLevels(o) : 0;
                    const MotionSearchSamples s = prepareSearchSamples(p.current, p.reference, levels);
                    MotionSearchResult r = est.search(cc, s); // warm-up: kernel builds
                    std::vector<double> ms;
                    for (int i = 0; i < a.runs; ++i) {
                        r = est.search(cc, s);
                        ms.push_back(est.lastKernelMilliseconds());
                    }
                    const double searchMs = median(ms);
                    const MotionField f =
                        comp.decideModes(cc, p.current, p.reference, nullptr, r.grid, r.vectors, nullptr, {});
                    const Volume pred = comp.compensate(cc, f, p.reference, nullptr);
                    double rm = 0;
                    const double ps = psnrOver(p.current, pred, rm);
                    std::size_t inter = 0;
                    for (BlockMode bm : f.modes)
                        inter += bm == BlockMode::Forward;
                    const std::size_t bytes = encodeMotionField(f).size();
                    const char* method = m == MotionSearchMethod::Full ? "full" : "hierarchical";
                    csv << p.name << ',' << B << ',' << R << ',' << method << ',' << searchMs << ',' << ps
                        << ',' << rm << ',' << zeroPsnr << ',' << inter << ',' << bytes << ','
                        << double(bytes) * 8 / double(d.count()) << '\n';
                    rows.push_back({{"dataset", p.name},
                                    {"block", B},
                                    {"radius", R},
                                    {"method", method},
                                    {"search_ms", searchMs},
                                    {"prediction_psnr_db", jnum(ps)},
                                    {"residual_rmse", rm},
                                    {"zero_motion_psnr_db", jnum(zeroPsnr)},
                                    {"inter_blocks", inter},
                                    {"blocks", f.modes.size()},
                                    {"motion_bytes", bytes}});
                    std::cerr << "  B " << B << " R " << R << " " << method << ": search "
                              << formatFixed(searchMs, 1) << " ms, prediction PSNR " << formatFixed(ps, 2)
                              << " dB (RMSE " << formatFixed(rm, 4) << "), inter " << inter << "/"
                              << f.modes.size() << ", vectors " << bytes << " B\n";
                }
        // Kernel against the C++ reference in the same run, interleaved (kernel, reference, kernel, ...).
        if (!a.reference) continue;
        for (const MotionSearchOptions& o :
             {MotionSearchOptions{8, 2, MotionSearchMethod::Full, MotionCost::Ssd, true},
              MotionSearchOptions{8, 4, MotionSearchMethod::Hierarchical, MotionCost::Ssd, true}}) {
            MotionEstimator est(cc, o);
            const int levels = o.method == MotionSearchMethod::Hierarchical ? hierarchyLevels(o) : 0;
            const MotionSearchSamples s = prepareSearchSamples(p.current, p.reference, levels);
            est.search(cc, s);
            std::vector<double> kernelMs, wallMs, refMs;
            bool same = true;
            for (int i = 0; i < std::max(1, a.runs); ++i) {
                Stopwatch sw;
                const MotionSearchResult k = est.search(cc, s);
                wallMs.push_back(sw.milliseconds());
                kernelMs.push_back(est.lastKernelMilliseconds());
                Stopwatch rw;
                const MotionSearchResult r = searchMotionReference(s, o);
                refMs.push_back(rw.milliseconds());
                same = same && k.vectors == r.vectors && k.costs == r.costs;
            }
            const char* method = o.method == MotionSearchMethod::Full ? "full" : "hierarchical";
            const double km = median(kernelMs), wm = median(wallMs), rm = median(refMs);
            speed.push_back({{"dataset", p.name},
                             {"what", std::string("search B8 R") + std::to_string(o.radius) + " " + method},
                             {"kernel_ms", km},
                             {"kernel_wall_ms", wm},
                             {"reference_ms", rm},
                             {"identical", same}});
            std::cerr << "  search B 8 R " << o.radius << " " << method << ": kernel " << formatFixed(km, 1)
                      << " ms (wall " << formatFixed(wm, 1) << ") against C++ reference "
                      << formatFixed(rm, 1) << " ms = " << formatFixed(rm / wm, 1)
                      << "x faster wall-clock, results " << (same ? "identical" : "DIFFERENT") << '\n';
        }
        {
            MotionEstimator est(cc, {8, 2});
            const MotionSearchResult r = est.search(cc, p.current, p.reference);
            const MotionField f =
                comp.decideModes(cc, p.current, p.reference, nullptr, r.grid, r.vectors, nullptr, {});
            comp.compensate(cc, f, p.reference, nullptr);
            std::vector<double> kernelMs, wallMs, refMs;
            for (int i = 0; i < std::max(1, a.runs); ++i) {
                Stopwatch sw;
                comp.compensate(cc, f, p.reference, nullptr);
                wallMs.push_back(sw.milliseconds());
                kernelMs.push_back(comp.lastKernelMilliseconds());
                Stopwatch rw;
                compensateReference(f, p.reference, nullptr);
                refMs.push_back(rw.milliseconds());
            }
            const double km = median(kernelMs), wm = median(wallMs), rm = median(refMs);
            speed.push_back({{"dataset", p.name},
                             {"what", "OBMC B8"},
                             {"kernel_ms", km},
                             {"kernel_wall_ms", wm},
                             {"reference_ms", rm},
                             {"identical", nullptr}});
            std::cerr << "  OBMC B 8: kernel " << formatFixed(km, 1) << " ms (wall " << formatFixed(wm, 1)
                      << ") against C++ reference " << formatFixed(rm, 1)
                      << " ms = " << formatFixed(rm / wm, 1) << "x faster wall-clock\n";
        }
    }
    nlohmann::json j{
        {"device", cc.device().name}, {"runs", a.runs}, {"rows", rows}, {"kernel_vs_reference", speed}};
    writeOutput(a.csv, csv.str());
    if (!a.json.empty()) writeOutput(a.json, j.dump(1));
}

} // namespace

void addMotionBench(CLI::App& bench, GlobalOptions& global) {
    auto* b =
        bench.add_subcommand("motion", "Motion search: time against block size, radius and method, with the "
                                       "prediction error, and the kernels against their C++ references");
    auto a = std::make_shared<MotionBenchArgs>();
    b->add_option("--data", a->data, "Shared data directory")->capture_default_str();
    b->add_option("--dataset", a->filter,
                  "Only data sets whose name contains this text (viscous, isabel, mri)");
    b->add_option("--block", a->blocks, "Block sizes (default 4 8 16)");
    b->add_option("--radius", a->radii, "Search radii (default 1 2 4 8)");
    b->add_option("--runs", a->runs, "Timed runs per measurement (median)")->capture_default_str();
    b->add_option("--mri-crop", a->mriCrop, "Edge of the central cube of the BrainWeb MRI that is shifted")
        ->capture_default_str();
    b->add_flag("!--no-reference", a->reference, "Skip timing the C++ references");
    b->add_option("--csv", a->csv, "CSV output file (default: stdout)");
    b->add_option("--json", a->json, "JSON output file");
    b->callback([a, &global] {
        if (a->runs < 1) throw UsageError("--runs must be at least 1");
        for (std::size_t B : a->blocks)
            validate(MotionSearchOptions{.blockSize = B});
        for (int R : a->radii)
            validate(MotionSearchOptions{.radius = R});
        benchMotion(*a, global);
    });
}

} // namespace volcl::cli
