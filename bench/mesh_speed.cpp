// volcl-bench-mesh: read + repair + adjacency time of mesh files, and the build time of the generated
// Marschner-Lobb mesh (median of N runs each). Usage: volcl-bench-mesh [-n runs] [--ml CELLS] [--write-ml OUT.vtu]
// files... (--write-ml writes the generated mesh instead, as the >= 1 M tet input of `volcl bench render`).
#include "host/mesh/MeshGenerator.hpp"
#include "host/mesh/MeshIo.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

int main(int argc, char** argv) {
    int runs = 5;
    std::size_t ml = 64;
    std::vector<std::string> files;
    std::string writeMl;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "-n" && i + 1 < argc)
            runs = std::stoi(argv[++i]);
        else if (a == "--ml" && i + 1 < argc)
            ml = std::stoul(argv[++i]);
        else if (a == "--write-ml" && i + 1 < argc)
            writeMl = argv[++i];
        else
            files.push_back(a);
    }
    if (!writeMl.empty()) {
        const volcl::mesh::TetMesh m = volcl::mesh::marschnerLobbMesh(ml);
        volcl::mesh::writeVtu(m, writeMl);
        std::printf("%s: %zu tets, %zu points\n", writeMl.c_str(), m.tetCount(), m.pointCount());
        return 0;
    }
    auto median = [&](auto&& f) {
        std::vector<double> t;
        std::size_t tets = 0;
        for (int r = 0; r < runs; ++r) {
            const auto t0 = std::chrono::steady_clock::now();
            tets = f().tetCount();
            t.push_back(
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
        }
        std::sort(t.begin(), t.end());
        return std::pair{t[t.size() / 2], tets};
    };
    std::printf("mesh,tets,median_ms,tets_per_s\n");
    for (const std::string& f : files) {
        const auto [ms, tets] = median([&] { return volcl::mesh::readMesh(f); });
        std::printf("%s,%zu,%.1f,%.3g\n", f.c_str(), tets, ms, double(tets) / ms * 1e3);
    }
    if (ml > 0) {
        const auto [ms, tets] = median([&] { return volcl::mesh::marschnerLobbMesh(ml); });
        std::printf("marschner_lobb_%zu^3,%zu,%.1f,%.3g\n", ml, tets, ms, double(tets) / ms * 1e3);
    }
}
