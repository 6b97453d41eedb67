// volcl-bench-kbuffer: k-buffer mesh rendering per mesh, face order and k (ms/frame, stage times, tets/s,
// out-of-order pops), and the dynamic level of detail held to a frame-time target by the viewer's controller.
// Usage: volcl-bench-kbuffer [--size 512] [--runs 5] [--k 2,4,6,8] [--sort centroid,mpvo,convexified] [--ml CELLS]
//        [--lod-target MS] [--frames N] [--q-var N] [--table N] [--lengths L] [--rmse] [--dump DIR] [--split RATIO BUDGET] MESH...
// --sort: the face orders (render.sort) measured, each with every k (default centroid, the sweeps before the
// visibility order; faces are cut by --split for the centroid sort only);
// --rmse: RGBA RMSE of every k against the exact double reference (meshReferenceRender) of the same scene;
// --dump: EXR images of the reference and every k into DIR; --deep-mirror: with --rmse, the C++ mirror at k = 8,
// 32, 256 (toward exact order); --misorder-all: count out-of-order pops also on meshes above 300 k tets.
#include "apps/viewer/AdaptiveQuality.hpp"
#include "core/runtime/Timing.hpp"
#include "host/mesh/MeshGenerator.hpp"
#include "host/mesh/MeshIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/CameraFraming.hpp"
#include "render/Reference.hpp"
#include "render/mesh/KBufferReference.hpp"
#include "render/mesh/KBufferRenderer.hpp"
#include "render/mesh/MeshReference.hpp"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <sstream>
#include <string>
#include <vector>

using namespace volcl;

namespace {

/// The benchmark TF over the mesh's value range: a blue-orange-white ramp whose peak extinction gives an
/// optical depth of 4 across the box diagonal (semi-transparent everywhere: every face is composited).
TransferFunction benchTf(const mesh::TetMesh& m) {
    double d2 = 0;
    for (int i = 0; i < 3; ++i)
        d2 += (m.boundsMax[i] - m.boundsMin[i]) * (m.boundsMax[i] - m.boundsMin[i]);
    const double peak = 4.0 / std::sqrt(d2);
    std::ostringstream js;
    js << R"({"domain": [0, 1], "color": [[0, 0.1, 0.2, 0.9], [0.5, 1.0, 0.6, 0.2], [1, 1.0, 1.0, 1.0]],)"
       << R"("extinction": [[0, )" << 0.05 * peak << "], [0.5, " << 0.6 * peak << "], [0.8, " << peak
       << "], [1, " << 0.3 * peak << "]]}";
    const double lo = m.valueMin, hi = m.valueMax > m.valueMin ? m.valueMax : m.valueMin + 1.0;
    return TransferFunction::fromJson(js.str()).rescaled({lo, hi});
}

/// Orthographic view from azimuth 35 degrees, elevation 25 degrees, framing the box (ParaView's reset).
int gTableSize = 256, gTableLengths = 16;

Scene benchScene(const WorldBox& box, int size, double azimuth = 35.0) {
    Scene s;
    s.width = s.height = size;
    s.camera = frameBox(box, orbitDirection(azimuth, 25.0), Projection::Orthographic, 30.0, 1.0);
    s.preintegration = Preintegration::Table3d;
    s.tableSize = gTableSize;
    s.tableLengths = gTableLengths;
    s.earlyTermination = 0.995;
    return s;
}

WorldBox boxOf(const mesh::TetMesh& m) {
    WorldBox b;
    for (int i = 0; i < 3; ++i) {
        b.origin[i] = m.boundsMin[i];
        b.extent[i] = m.boundsMax[i] - m.boundsMin[i];
    }
    return b;
}

/// CPU time of the whole process (every thread), milliseconds: on a shared machine the work a frame costs,
/// which the wall time hides behind the other processes' load.
double processCpuMs() {
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) * 1e-6;
}

std::vector<int> parseList(const std::string& s) {
    std::vector<int> v;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ','))
        v.push_back(std::stoi(item));
    return v;
}

/// The command line: meshes, image size, runs, k values and the optional studies.
struct Options {
    int size = 512, runs = 5, frames = 40, qVar = -1;
    std::vector<int> ks{2, 4, 6, 8};
    std::vector<MeshSort> sorts{MeshSort::Centroid}; ///< face orders (render.sort), each with every k
    std::size_t ml = 0;
    double lodTarget = 0;
    bool rmse = false, deepMirror = false, misorderAll = false;
    FaceSplitOptions split;
    std::string dumpDir;
    std::vector<std::string> files;
};

Options parseOptions(int argc, char** argv) {
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto next = [&] { return std::string(argv[++i]); };
        if (a == "--size" && i + 1 < argc)
            o.size = std::stoi(next());
        else if (a == "--runs" && i + 1 < argc)
            o.runs = std::stoi(next());
        else if (a == "--k" && i + 1 < argc)
            o.ks = parseList(next());
        else if (a == "--sort" && i + 1 < argc) {
            o.sorts.clear();
            std::stringstream ss(next());
            std::string item;
            while (std::getline(ss, item, ','))
                o.sorts.push_back(parseMeshSort(item));
        } else if (a == "--ml" && i + 1 < argc)
            o.ml = std::stoul(next());
        else if (a == "--lod-target" && i + 1 < argc)
            o.lodTarget = std::stod(next());
        else if (a == "--frames" && i + 1 < argc)
            o.frames = std::stoi(next());
        else if (a == "--rmse")
            o.rmse = true;
        else if (a == "--deep-mirror")
            o.deepMirror = true;
        else if (a == "--misorder-all")
            o.misorderAll = true;
        else if (a == "--split" && i + 2 < argc) {
            o.split.ratio = std::stod(next());
            o.split.budget = std::stod(next());
        } else if (a == "--dump" && i + 1 < argc)
            o.dumpDir = next();
        else if (a == "--table" && i + 1 < argc)
            gTableSize = std::stoi(next());
        else if (a == "--lengths" && i + 1 < argc)
            gTableLengths = std::stoi(next());
        else if (a == "--q-var" && i + 1 < argc)
            o.qVar = std::stoi(next());
        else
            o.files.push_back(a);
    }
    return o;
}

} // namespace

int main(int argc, char** argv) try {
    const Options opt = parseOptions(argc, argv);
    const auto& [size, runs, frames, qVar, kList, sorts, ml, lodTarget, rmse, deepMirror, misorderAll, split,
                 dumpDir, files] = opt;
    // Every (sort, k) pair is one configuration: ks[i] and sortOf[i] name configuration i.
    std::vector<int> ks;
    std::vector<MeshSort> sortOf;
    for (MeshSort so : sorts)
        for (int k : kList) {
            ks.push_back(k);
            sortOf.push_back(so);
        }
    ComputeContext cc;
    std::fprintf(stderr, "device: %s\n", cc.device().name.c_str());
    struct Input {
        std::string name;
        mesh::TetMesh mesh;
    };
    std::vector<Input> inputs;
    for (const auto& f : files) {
        mesh::MeshReadOptions o;
        if (qVar >= 0) o.qVariable = qVar;
        inputs.push_back({std::filesystem::path(f).filename().string(), mesh::readMesh(f, o)});
    }
    if (ml > 0) inputs.push_back({"marschner_lobb_" + std::to_string(ml), mesh::marschnerLobbMesh(ml)});

    std::printf(
        "mesh,tets,faces,sort,k,size,median_ms,cpu_ms,kernel_ms,project_ms,keys_ms,sort_ms,place_ms,bin_ms,"
        "raster_ms,"
        "tets_per_s,misordered_pops_per_pixel,rmse,reference_ms\n");
    for (const Input& in : inputs) {
        const TransferFunction tf = benchTf(in.mesh);
        const Scene scene = benchScene(boxOf(in.mesh), size);
        std::vector<std::unique_ptr<KBufferRenderer>> rs;
        for (std::size_t i = 0; i < ks.size(); ++i) {
            Scene sorted = scene;
            sorted.meshSort = sortOf[i];
            rs.push_back(std::make_unique<KBufferRenderer>(cc, in.mesh, tf, sorted, ks[i], split));
            rs.back()->render(); // warm-up: first launches build and page in
        }
        ImageBuffer ref;
        double refMs = -1;
        if (rmse) {
            Stopwatch sw;
            ref = meshReferenceRender(in.mesh, tf, scene);
            refMs = sw.milliseconds();
            if (!dumpDir.empty()) writeImage(ref, dumpDir + "/" + in.name + "_reference.exr");
        }
        std::vector<double> errors(ks.size(), -1.0);
        if (rmse && deepMirror) { // the C++ mirror with deeper buffers: toward the A-buffer (exact order)
            for (int deep : {8, 32, 256}) {
                KBufferMirrorInput mi{&rs[0]->geometry(),   &rs[0]->geometry().scalars, &rs[0]->faces(),
                                      rs[0]->frameParams(), &rs[0]->tableValues(),      deep};
                mi.order = rs[0]->hostOrder();
                KBufferMirrorStats st;
                const ImageBuffer img = kbufferMirrorRender(mi, &st);
                std::fprintf(stderr, "mirror k %d: RMSE %.4g, misordered pops per pixel %.4g\n", deep,
                             imageRmse(img, ref), double(st.misorderedPops) / double(img.width * img.height));
            }
        }
        for (std::size_t i = 0; i < ks.size() && rmse; ++i) {
            const ImageBuffer img = rs[i]->render();
            errors[i] = imageRmse(img, ref);
            if (!dumpDir.empty())
                writeImage(img, dumpDir + "/" + in.name + "_" + std::string(meshSortName(sortOf[i])) + "_k" +
                                    std::to_string(ks[i]) + ".exr");
        }
        std::vector<std::vector<double>> wall(ks.size()), kern(ks.size()), cpu(ks.size());
        std::vector<KBufferStageTimes> stages(ks.size());
        for (int run = 0; run < runs; ++run) // interleaved, so load changes hit every k alike
            for (std::size_t i = 0; i < ks.size(); ++i) {
                Stopwatch sw;
                const double c0 = processCpuMs();
                rs[i]->render();
                wall[i].push_back(sw.milliseconds());
                cpu[i].push_back(processCpuMs() - c0);
                kern[i].push_back(rs[i]->lastKernelMilliseconds());
                if (run == runs / 2) stages[i] = rs[i]->lastStageTimes();
            }
        for (std::size_t i = 0; i < ks.size(); ++i) {
            // Out-of-order pops from the C++ mirror (same fragments), per covered pixel, at a small image.
            double misordered = -1;
            if (in.mesh.tetCount() <= 300000 || misorderAll) {
                Scene small = scene;
                small.width = small.height = 128;
                small.meshSort = sortOf[i];
                KBufferRenderer probe(cc, in.mesh, tf, small, ks[i], split);
                probe.render(); // the host's face order of this view, when the sort is exact
                KBufferMirrorInput mi{&probe.geometry(),   &probe.geometry().scalars, &probe.faces(),
                                      probe.frameParams(), &probe.tableValues(),      ks[i]};
                mi.order = probe.hostOrder();
                KBufferMirrorStats st;
                kbufferMirrorRender(mi, &st);
                misordered = double(st.misorderedPops) / (128.0 * 128.0);
                std::fprintf(stderr, "%s k %d at 128^2: %.1f fragments and %.1f pixel tests per pixel\n",
                             in.name.c_str(), ks[i], double(st.fragments) / (128.0 * 128.0),
                             double(st.pixelTests) / (128.0 * 128.0));
            }
            std::fprintf(stderr, "%s: %s\n", in.name.c_str(), rs[i]->statistics().c_str());
            const double ms = median(wall[i]);
            const KBufferStageTimes& t = stages[i];
            std::printf(
                "%s,%zu,%zu,%s,%d,%d,%.1f,%.1f,%.1f,%.1f,%.1f,%.1f,%.1f,%.1f,%.1f,%.3g,%.4g,%.3g,%.0f\n",
                in.name.c_str(), in.mesh.tetCount(), rs[i]->faces().faces.size(),
                std::string(meshSortName(sortOf[i])).c_str(), ks[i], size, ms, median(cpu[i]),
                median(kern[i]), t.project, t.keys, t.sort, t.place, t.bin, t.raster,
                double(in.mesh.tetCount()) / ms * 1e3, misordered, errors[i], refMs);
            std::fflush(stdout);
        }
        if (lodTarget > 0) {
            // Callahan's dynamic LOD: the viewer's controller sizes the internal-face fraction so a frame fits
            // the target while the camera orbits. maxStepScale 1: its work is the face fraction alone.
            viewer::AdaptiveQualityOptions o;
            o.targetMs = lodTarget;
            o.maxStepScale = 1.0;
            o.minResolutionScale = 0.01; // work down to 1e-4: boundary faces only
            viewer::AdaptiveQuality aq(o);
            KBufferRenderer& r = *rs[0];
            std::printf("# lod,mesh,frame,k,fraction,faces_drawn,frame_ms,target_ms\n");
            for (int f = 0; f < frames; ++f) {
                Scene s = benchScene(boxOf(in.mesh), size, 35.0 + 4.0 * f);
                r.setView(*s.camera, size, size, s.step);
                const viewer::QualityLevel level = aq.next();
                r.setLodFraction(level.work());
                Stopwatch sw;
                r.render();
                const double ms = sw.milliseconds();
                aq.report(level, ms);
                std::printf("lod,%s,%d,%d,%.4f,%zu,%.1f,%.1f\n", in.name.c_str(), f, r.k(), level.work(),
                            r.facesDrawn(), ms, lodTarget);
                std::fflush(stdout);
            }
            r.setLodFraction(1.0);
        }
    }
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "volcl-bench-kbuffer: %s\n", e.what());
    return 1;
}
