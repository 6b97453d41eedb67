// `volcl bench mesh`: visibility sorting of tet meshes per method (centroid, MPVO, convexified): tets/s against
// the centroid sort in the same run, cycles broken, the convexification's build, and order errors from the ray
// oracle.
#include "apps/bench/BenchCommand.hpp"
#include "apps/bench/BenchOutput.hpp"

#include "apps/cli/CliParsing.hpp"
#include "apps/cli/MeshInfo.hpp"
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "core/runtime/Timing.hpp"
#include "host/mesh/MeshIo.hpp"
#include "render/mesh/VisibilityOracle.hpp"
#include "render/mesh/VisibilitySort.hpp"

#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace volcl::cli {
namespace {

struct MeshSortBenchArgs {
    std::vector<std::string> meshes;
    MeshReadFlags read;
    int runs = 5;
    int views = 8;
    int rays = 8;
    std::string csv;
};

/// Half the views orthographic, half perspective from 2.5 bounding radii, on an orbit at 30 degrees elevation
/// (the perspective ones half-way between the orthographic ones).
std::vector<SortView> orbitViews(const mesh::TetMesh& m, int count) {
    const Vec3 lo = m.boundsMin, hi = m.boundsMax;
    const Vec3 centre = scale(add(lo, hi), 0.5);
    const double radius = 0.5 * norm(sub(hi, lo));
    std::vector<SortView> out;
    const double pi = 3.141592653589793, el = pi / 6.0;
    for (int i = 0; i < count; ++i) {
        const double az =
            2.0 * pi * (i / 2) / std::max(1, count / 2) + (i % 2 ? pi / std::max(1, count) : 0.0);
        const Vec3 toEye{std::cos(az) * std::cos(el), std::sin(az) * std::cos(el), std::sin(el)};
        SortView v;
        v.perspective = i % 2 == 1;
        v.eye = add(centre, scale(toEye, 2.5 * radius));
        v.direction = scale(toEye, -1.0);
        out.push_back(v);
    }
    return out;
}

void benchMeshSort(const MeshSortBenchArgs& a) {
    const MeshSort methods[] = {MeshSort::Centroid, MeshSort::Mpvo, MeshSort::Convexified};
    std::ostringstream csv;
    csv << "mesh,tets,method,median_ms,tets_per_s,ratio_to_centroid,cycles_broken,oracle_pairs,oracle_"
           "violations,"
           "convexify_s,aux_cells,load\n";
    std::cout << "visibility sorting: " << a.views << " views (orthographic and perspective), " << a.runs
              << " interleaved runs, one thread; load average " << loadAverage() << '\n';
    for (const std::string& path : a.meshes) {
        const mesh::TetMesh m = mesh::readMesh(path, a.read.toReadOptions());
        VisibilitySorter sorter(m);
        const ConvexificationStats& cs = sorter.convexification();
        std::cout << path << ": " << m.tetCount() << " tets, " << (meshIsConvex(m) ? "convex" : "not convex")
                  << "; convexification " << formatFixed(cs.seconds, 2) << " s: " << cs.delaunayTets
                  << " Delaunay tets, " << cs.auxiliaryCells << " auxiliary cells, " << cs.exactLinks
                  << " exact + " << cs.geometricLinks << " geometric + " << cs.contactLinks
                  << " contact links, " << cs.openBoundaryFaces << " boundary faces left open"
                  << (cs.delaunayError.empty() ? "" : "; " + cs.delaunayError) << '\n';
        const std::vector<SortView> views = orbitViews(m, a.views);
        struct Column {
            std::vector<double> ms;
            std::size_t cycles = 0;
            OrderCheck check;
        };
        Column col[3];
        for (int run = 0; run < a.runs; ++run)
            for (const SortView& v : views)
                for (int k = 0; k < 3; ++k) {
                    const VisibilityOrder o = sorter.sort(v, methods[k]);
                    col[k].ms.push_back(o.seconds * 1e3);
                    if (run > 0) continue;
                    col[k].cycles += o.cyclesBroken;
                    if (a.rays > 0) {
                        const OrderCheck c = checkOrderAlongRays(m, o.tets, v, a.rays);
                        col[k].check.rays += c.rays;
                        col[k].check.pairs += c.pairs;
                        col[k].check.violations += c.violations;
                    }
                }
        const double centroidMs = median(col[0].ms);
        std::cout << "  method        ms/sort   M tets/s   x centroid   cycles broken   oracle violations\n";
        for (int k = 0; k < 3; ++k) {
            const double ms = median(col[k].ms);
            const double rate = double(m.tetCount()) / (ms * 1e-3);
            const double share =
                col[k].check.pairs ? double(col[k].check.violations) / double(col[k].check.pairs) : 0.0;
            std::cout << "  " << std::left << std::setw(12) << meshSortName(methods[k]) << std::right
                      << std::setw(9) << formatFixed(ms, 2) << std::setw(11) << formatFixed(rate * 1e-6, 2)
                      << std::setw(13) << formatFixed(ms / centroidMs, 2) << std::setw(16) << col[k].cycles
                      << "   " << col[k].check.violations << " of " << col[k].check.pairs << " pairs ("
                      << formatFixed(100.0 * share, 3) << " %)\n";
            csv << path << ',' << m.tetCount() << ',' << meshSortName(methods[k]) << ',' << ms << ',' << rate
                << ',' << ms / centroidMs << ',' << col[k].cycles << ',' << col[k].check.pairs << ','
                << col[k].check.violations << ',' << cs.seconds << ',' << cs.auxiliaryCells << ",\""
                << loadAverage() << "\"\n";
        }
    }
    std::cout << "load average now " << loadAverage() << '\n';
    if (!a.csv.empty()) writeOutput(a.csv, csv.str());
}

} // namespace

void addMeshBench(CLI::App& bench, GlobalOptions&) {
    CLI::App* b = bench.add_subcommand(
        "mesh",
        "Tetrahedral meshes: visibility sorting per method (centroid, mpvo, convexified), tets/s against "
        "the centroid sort, cycles broken, convexification time, order errors along rays");
    auto a = std::make_shared<MeshSortBenchArgs>();
    b->add_option("meshes", a->meshes, "Mesh files (.vtu, .vtk, PLOT3D)")->required();
    a->read.add(*b);
    b->add_option("--runs", a->runs, "Interleaved timed runs over every view (median)")
        ->capture_default_str();
    b->add_option("--views", a->views, "Views on an orbit, half of them perspective")->capture_default_str();
    b->add_option("--rays", a->rays,
                  "Oracle rays per axis and view (brute force: rays^2 x tets clips per view; 0: no oracle)")
        ->capture_default_str();
    b->add_option("--csv", a->csv, "CSV output file (one row per mesh and method)");
    b->callback([a] {
        if (a->runs < 1 || a->views < 1 || a->rays < 0)
            throw UsageError("bench mesh: --runs and --views must be at least 1, --rays at least 0");
        benchMeshSort(*a);
    });
}

} // namespace volcl::cli
