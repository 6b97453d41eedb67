// volcl-bench-lod-oracle: what a level-of-detail choice could achieve on one view of a .vcz, measured rather
// than estimated. It renders the view at level 0 (the reference), then every reachable brick alone at each
// coarser level, so each (brick, level) gets its measured image error (sum of squared RGBA differences from
// the reference). A greedy allocation over those measurements (coarsen the step that saves the most voxels
// per squared error added, errors assumed additive) gives the fewest voxels an oracle needs for a target
// RMSE; each allocation is rendered again to check its real RMSE. It also prints the view's footprint
// (pixels the volume spans), every level drawn uniformly, a supersampled (pixel-averaged) reference when
// asked, and the estimate `lod auto` makes at each lod_error, so estimate and oracle meet on one curve.
// Usage: volcl-bench-lod-oracle FILE.vcz SCENE.json TF.json [--zoom Z] [--size PX] [--probe-size PX, 0: none]
//        [--supersample N] [--lod-errors a,b,c] [--targets a,b,c] [--bricks-csv OUT.csv]
// Output: `key: value` lines on stdout (bench/results/multires/multires-oracle-*.log).
#include "core/AtomicFile.hpp"
#include "core/runtime/Timing.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/VecMath.hpp"
#include "render/bricks/BrickRenderer.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/LodStatistics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

using namespace volcl;

namespace {

std::vector<double> parseList(const std::string& s) {
    std::vector<double> v;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ','))
        v.push_back(std::stod(item));
    return v;
}

double sse(const ImageBuffer& a, const ImageBuffer& b) {
    double s = 0;
    for (std::size_t i = 0; i < a.pixels.size(); ++i)
        s += double(a.pixels[i] - b.pixels[i]) * double(a.pixels[i] - b.pixels[i]);
    return s;
}

double rmse(const ImageBuffer& a, const ImageBuffer& b) {
    return std::sqrt(sse(a, b) / double(a.pixels.size()));
}

/// Box-filters an (n w) x (n h) RGBA image down to w x h: the pixel-area average.
ImageBuffer downsample(const ImageBuffer& big, int n) {
    const int w = big.width / n, h = big.height / n, nc = big.channelCount();
    ImageBuffer out(w, h, big.channels);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < nc; ++c) {
                double s = 0;
                for (int j = 0; j < n; ++j)
                    for (int i = 0; i < n; ++i)
                        s += big.pixels[(std::size_t(y * n + j) * std::size_t(big.width) +
                                         std::size_t(x * n + i)) *
                                            std::size_t(nc) +
                                        std::size_t(c)];
                out.pixels[(std::size_t(y) * std::size_t(w) + std::size_t(x)) * std::size_t(nc) +
                           std::size_t(c)] = float(s / double(n * n));
            }
    return out;
}

struct Step {
    std::size_t brick;
    int level; ///< the level this step coarsens to
    double dSse, dVoxels;
};

struct Options {
    std::string file, sceneFile, tfFile, bricksCsv;
    double zoom = 1.0;
    int size = 512, probe = 256, super = 0;
    std::vector<double> lodErrors{0.0025, 0.005, 0.01, 0.02, 0.05}, targets{2.5e-4, 5e-4, 1e-3, 2e-3};
};

Options parseOptions(int argc, char** argv) {
    Options o;
    o.file = argv[1];
    o.sceneFile = argv[2];
    o.tfFile = argv[3];
    for (int i = 4; i + 1 < argc; i += 2) {
        const std::string k = argv[i], v = argv[i + 1];
        if (k == "--zoom")
            o.zoom = std::stod(v);
        else if (k == "--size")
            o.size = std::stoi(v);
        else if (k == "--probe-size")
            o.probe = std::stoi(v);
        else if (k == "--supersample")
            o.super = std::stoi(v);
        else if (k == "--lod-errors")
            o.lodErrors = parseList(v);
        else if (k == "--targets")
            o.targets = parseList(v);
        else if (k == "--bricks-csv")
            o.bricksCsv = v;
        else
            throw std::runtime_error("unknown option " + k);
    }
    return o;
}

// The view every measurement renders: the file's bricks, the TF and the scene at the full size.
struct OracleView {
    ComputeContext& cc;
    std::shared_ptr<const VczReader> reader;
    const VczHeader& h;
    const TransferFunction& tf;
    const Scene& s;
    int size;
};

// Footprint: the volume's projected box and the pixels something visible lands on.
void printFootprint(const ImageBuffer& ref, int size) {
    int x0 = size, x1 = -1, y0 = size, y1 = -1;
    std::size_t covered = 0;
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x)
            if (ref.pixels[(std::size_t(y) * std::size_t(size) + std::size_t(x)) * 4 + 3] > 1e-3f) {
                ++covered;
                x0 = std::min(x0, x);
                x1 = std::max(x1, x);
                y0 = std::min(y0, y);
                y1 = std::max(y1, y);
            }
    std::printf("footprint: visible pixels span %d x %d of %d x %d; %zu pixels (%.1f %%) have alpha > "
                "1e-3\n",
                x1 - x0 + 1, y1 - y0 + 1, size, size, covered,
                100.0 * double(covered) / double(std::size_t(size) * std::size_t(size)));
}

// Every level drawn uniformly (what forcing costs), against the reference and, with --supersample, the
// supersampled one.
void printUniformLevels(const OracleView& v, BrickRenderer& full, const ImageBuffer& ref, int super) {
    std::vector<ImageBuffer> uniform;
    for (int l = 1; l <= v.h.levels; ++l) {
        full.setForcedLevels(std::vector<int>(v.h.brickCount(), l));
        uniform.push_back(full.render());
        std::printf("uniform level %d: RMSE %.3e, voxels %zu\n", l, rmse(uniform.back(), ref),
                    full.lastStats().voxelsDecoded);
    }
    full.setForcedLevels({});
    if (super > 1) {
        Scene ss = v.s;
        ss.width = ss.height = v.size * super;
        BrickRenderer big(v.cc, v.reader, 0, v.tf, ss);
        const ImageBuffer avg = downsample(big.render(), super);
        std::printf("supersampled %dx%d reference: full RMSE %.3e\n", super, super, rmse(ref, avg));
        for (int l = 1; l <= v.h.levels; ++l)
            std::printf("supersampled %dx%d reference: uniform level %d RMSE %.3e\n", super, super, l,
                        rmse(uniform[std::size_t(l - 1)], avg));
    }
}

// lod auto as estimated, at each lod_error.
void printLodAutoEstimates(const OracleView& v, const ImageBuffer& ref, std::size_t voxels0,
                           const std::vector<double>& lodErrors) {
    for (double e : lodErrors) {
        Scene a = v.s;
        a.lod = LodMode::Auto;
        a.lodError = e;
        BrickRenderer r(v.cc, v.reader, 0, v.tf, a);
        Stopwatch sw;
        const ImageBuffer img = r.render();
        const double ms = sw.milliseconds();
        std::printf(
            "estimate lod_error %g: RMSE %.3e, voxels %zu (%.2fx fewer), frame %.0f ms, kernel %.0f ms, "
            "decode %.0f ms\n",
            e, rmse(img, ref), r.lastStats().voxelsDecoded,
            double(voxels0) / double(r.lastStats().voxelsDecoded), ms, r.lastKernelMilliseconds(),
            r.lastStats().decodeMs);
    }
}

// What lod auto sees of this view (at the full size), to set its estimate beside the measurement.
struct Estimate {
    const VczHeader& h;
    BrickView view;
    std::optional<LodStatistics> stats;

    Estimate(const OracleView& v, const std::string& file)
        : h(v.h), stats(LodStatistics::fromHeader(v.h, file)) {
        view.camera = *v.s.camera;
        view.width = view.height = v.size;
        view.lod = LodMode::Auto;
        view.tableNodes = v.s.preintegration != Preintegration::None ? v.s.tableSize : 0;
    }
    const LodStatistics* statistics() const { return stats ? &*stats : nullptr; }
    /// CSV columns estimate, data_rms, pixels of brick `b` at level `l`.
    std::string columns(std::size_t b, int l, const TransferFunction& tf) const {
        std::ostringstream os;
        os << brickError(h, statistics(), 0, b, l, tf, view) << ',' << (stats ? stats->at(0, b, l).rms : -1.0)
           << ',' << brickPixels(h, b, view);
        return os.str();
    }
};

// --probe-size 0: the estimate only (per brick in --bricks-csv, without probes).
void writeEstimateCsv(const OracleView& v, const Estimate& est, const std::string& path) {
    std::ofstream out(path);
    out << "brick,level,voxels,estimate,data_rms,pixels\n";
    BrickView at0 = est.view;
    at0.lod = LodMode::Full;
    const BrickSelection sel0 = selectBricks(v.h, est.statistics(), 0, v.h.levels, v.tf, at0);
    for (std::size_t b = 0; b < v.h.brickCount(); ++b)
        for (int l = 1; l <= v.h.levels && sel0.level[b] >= 0; ++l)
            out << b << ',' << l << ',' << brickSamples(v.h, b, l).count() << ',' << est.columns(b, l, v.tf)
                << '\n';
}

// Measured per (brick, level): squared image error scaled to the full size, and voxels drawn.
struct Probes {
    std::vector<std::vector<double>> err, vox;
    BrickSelection sel; ///< the bricks the view reaches (level < 0: not reached)
};

// Per-brick probes at the probe size (a brick's share of the image MSE does not depend on the pixel
// count), scaled to the full size's pixel count; rows in --bricks-csv.
Probes measureProbes(const OracleView& v, const Estimate& est, const Options& o, double samples) {
    Scene p = v.s;
    p.width = p.height = o.probe;
    BrickRenderer pr(v.cc, v.reader, 0, v.tf, p);
    const ImageBuffer pref = pr.render();
    const double scale = double(o.size) * double(o.size) / (double(o.probe) * double(o.probe));
    const std::size_t nb = v.h.brickCount();
    Probes r;
    r.err.assign(nb, std::vector<double>(std::size_t(v.h.levels) + 1, 0.0));
    r.vox.assign(nb, std::vector<double>(std::size_t(v.h.levels) + 1, 0.0));
    r.sel = pr.lastSelection();
    std::ofstream csv;
    if (!o.bricksCsv.empty()) {
        csv.open(o.bricksCsv);
        csv << "brick,level,voxels,sse,rms_share,estimate,data_rms,pixels\n";
    }
    Stopwatch probeClock;
    std::size_t probes = 0;
    for (std::size_t b = 0; b < nb; ++b) {
        if (r.sel.level[b] < 0) continue;
        for (int l = 0; l <= v.h.levels; ++l) {
            r.vox[b][std::size_t(l)] = double(brickSamples(v.h, b, l).count());
            if (l == 0) continue;
            std::vector<int> forced(nb, 0);
            forced[b] = l;
            pr.setForcedLevels(forced);
            r.err[b][std::size_t(l)] = sse(pr.render(), pref) * scale;
            ++probes;
            if (csv)
                csv << b << ',' << l << ',' << r.vox[b][std::size_t(l)] << ',' << r.err[b][std::size_t(l)]
                    << ',' << std::sqrt(r.err[b][std::size_t(l)] / samples) << ',' << est.columns(b, l, v.tf)
                    << '\n';
        }
    }
    std::printf("probes: %zu renders at %d^2 in %.0f s\n", probes, o.probe,
                probeClock.milliseconds() / 1000.0);
    return r;
}

// The greedy allocation for a squared-error budget: levels of the `nb` bricks (-1: not reached), coarsening the
// step that saves the most voxels per squared error added while the budget holds; `total` gets the
// predicted squared error.
std::vector<int> greedyLevels(const Probes& pr, std::size_t nb, int levels, double budget, double& total) {
    const auto& err = pr.err;
    const auto& vox = pr.vox;
    std::vector<int> level(nb, 0);
    for (std::size_t b = 0; b < nb; ++b)
        if (pr.sel.level[b] < 0) level[b] = -1;
    total = 0;
    double voxels = 0;
    for (std::size_t b = 0; b < nb; ++b)
        if (level[b] == 0) voxels += vox[b][0];
    for (;;) {
        // Best next step: a brick coarsened by one or more levels, most voxels saved per error added.
        double best = -1;
        std::size_t bb = 0;
        int bl = 0;
        for (std::size_t b = 0; b < nb; ++b) {
            if (level[b] < 0) continue;
            for (int l = level[b] + 1; l <= levels; ++l) {
                const double de = std::max(0.0, err[b][std::size_t(l)] - err[b][std::size_t(level[b])]);
                const double dv = vox[b][std::size_t(level[b])] - vox[b][std::size_t(l)];
                if (total + de > budget) continue;
                const double gain = dv / (de + 1e-30);
                if (gain > best) {
                    best = gain;
                    bb = b;
                    bl = l;
                }
            }
        }
        if (best < 0) break;
        total += std::max(0.0, err[bb][std::size_t(bl)] - err[bb][std::size_t(level[bb])]);
        voxels -= vox[bb][std::size_t(level[bb])] - vox[bb][std::size_t(bl)];
        level[bb] = bl;
    }
    return level;
}

// Greedy allocation per target, checked by rendering it at the full size.
void printOracle(const OracleView& v, BrickRenderer& full, const ImageBuffer& ref, std::size_t voxels0,
                 const Probes& pr, double samples, double target) {
    const std::size_t nb = v.h.brickCount();
    double total = 0;
    const std::vector<int> level = greedyLevels(pr, nb, v.h.levels, target * target * samples, total);
    std::vector<int> forced(nb, 0);
    std::size_t perLevel[8] = {};
    for (std::size_t b = 0; b < nb; ++b) {
        forced[b] = std::max(level[b], 0);
        if (level[b] >= 0) ++perLevel[level[b]];
    }
    full.setForcedLevels(forced);
    Stopwatch sw;
    const ImageBuffer img = full.render();
    const double ms = sw.milliseconds();
    std::size_t drawn = 0;
    for (std::size_t b = 0; b < nb; ++b)
        if (level[b] >= 0) drawn += brickSamples(v.h, b, level[b]).count();
    std::printf("oracle target %.2e: predicted RMSE %.3e, measured RMSE %.3e, voxels %zu (%.2fx fewer), "
                "bricks per level 0/1/2/3 %zu/%zu/%zu/%zu, frame %.0f ms, kernel %.0f ms\n",
                target, std::sqrt(total / samples), rmse(img, ref), drawn, double(voxels0) / double(drawn),
                perLevel[0], perLevel[1], perLevel[2], perLevel[3], ms, full.lastKernelMilliseconds());
    std::fflush(stdout);
}

int run(const Options& o) {
    ComputeContext cc;
    auto reader = std::make_shared<const VczReader>(readFileBytes(o.file), o.file);
    const VczHeader& h = reader->header();
    const TransferFunction tf = TransferFunction::fromFile(o.tfFile).fittedTo({0, 255});
    Scene s = Scene::fromFile(o.sceneFile);
    if (!s.camera) throw std::runtime_error("the scene needs a camera");
    s.camera->height *= o.zoom;
    s.width = s.height = o.size;
    s.lod = LodMode::Full;
    std::printf("file: %s\nzoom: %g (camera height %g world units over %d pixels: %.3f voxels per pixel)\n",
                o.file.c_str(), o.zoom, s.camera->height, o.size, s.camera->height / o.size);
    const OracleView v{cc, reader, h, tf, s, o.size};

    BrickRenderer full(cc, reader, 0, tf, s);
    const ImageBuffer ref = full.render();
    const std::size_t voxels0 = full.lastStats().voxelsDecoded;
    printFootprint(ref, o.size);
    std::printf("full: voxels %zu, kernel %.0f ms\n", voxels0, full.lastKernelMilliseconds());
    printUniformLevels(v, full, ref, o.super);
    printLodAutoEstimates(v, ref, voxels0, o.lodErrors);

    const Estimate est(v, o.file);
    if (o.probe <= 0) {
        if (!o.bricksCsv.empty()) writeEstimateCsv(v, est, o.bricksCsv);
        return 0;
    }
    const double samples = double(ref.pixels.size());
    const Probes probes = measureProbes(v, est, o, samples);
    for (double target : o.targets)
        printOracle(v, full, ref, voxels0, probes, samples, target);
    return 0;
}

} // namespace

int main(int argc, char** argv) {
    try {
        if (argc < 4) {
            std::fprintf(stderr,
                         "usage: %s FILE.vcz SCENE.json TF.json [--zoom Z] [--size PX] [--probe-size PX] "
                         "[--supersample N] [--lod-errors a,b] [--targets a,b] [--bricks-csv F]\n",
                         argv[0]);
            return 1;
        }
        return run(parseOptions(argc, argv));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "volcl-bench-lod-oracle: %s\n", e.what());
        return 1;
    }
}
