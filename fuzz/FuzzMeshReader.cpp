// Fuzz target for one tetrahedral-mesh reader, chosen at build time by VOLCL_FUZZ_EXTENSION (".vtu", ".vtk",
// ".xyz"). PLOT3D (VOLCL_FUZZ_SPLIT) takes two files: the first two bytes give the grid's length (little
// endian, clamped to the input), then the grid, then the q solution file; binary grids are full of zero
// bytes, so a separator byte would not do.
#include "core/Error.hpp"
#include "fuzz/FuzzSupport.hpp"
#include "host/mesh/MeshIo.hpp"

#include <algorithm>

#ifndef VOLCL_FUZZ_SPLIT
#define VOLCL_FUZZ_SPLIT 0
#endif

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace volcl;
    std::span<const std::uint8_t> grid(data, size);
    mesh::MeshReadOptions options;
    if (VOLCL_FUZZ_SPLIT) {
        if (size < 2) return 0;
        const std::size_t gridBytes = std::min<std::size_t>(data[0] | std::size_t{data[1]} << 8, size - 2);
        grid = std::span<const std::uint8_t>(data + 2, gridBytes);
        options.qFile = fuzz::writeScratchFile("input.q", {data + 2 + gridBytes, size - 2 - gridBytes});
    }
    const auto path = fuzz::writeScratchFile(std::string("input") + VOLCL_FUZZ_EXTENSION, grid);
    try {
        const mesh::TetMesh m = mesh::readMesh(path, options);
        // Touch what the renderers read: every tet's corners and the scalars (ASan catches a short array).
        double sum = 0;
        for (const auto& tet : m.tets)
            for (const auto v : tet)
                sum += m.points[v][0] + m.scalars[v];
        (void)sum;
    } catch (const Error&) {
        // Refused as corrupt (IoError) or unsupported (DataError): expected.
    }
    return 0;
}
