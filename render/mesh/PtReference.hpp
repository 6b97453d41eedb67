// The C++ mirror of the projected-tetrahedra kernels (cl/mesh/mesh_pt.cl): the same float arithmetic per cell and
// pixel, to test the OpenCL path, and a projected-tetrahedra renderer of any order on the host.
#pragma once

#include "host/image/ImageIo.hpp"
#include "host/mesh/TetMesh.hpp"
#include "render/mesh/KBufferFrame.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace volcl {

/// Inputs of one mirrored pt frame: the mesh and its normalised geometry (PtRenderer::geometry()), the cells
/// back to front, the frame parameters, the normalised clip planes, the table (float RGBA, PreintegrationTable
/// layout) and the NaN colour (straight r, g, b and extinction tau; used when `nanCells`).
struct PtMirrorInput {
    const mesh::TetMesh* mesh = nullptr;
    const KBufferGeometry* geometry = nullptr;
    const std::vector<std::uint32_t>* order = nullptr;
    VolclKBufferParams params{};
    VolclClipParams clip{};
    const std::vector<float>* table = nullptr;
    bool nanCells = false;
    std::array<float, 4> nanColor{0, 0, 0, 0};
};

/// The frame on the host: each cell's pixel rectangle from the projected vertices (kb_project), then per pixel
/// the cells covering it from the nearest to the farthest in `order`, each one's segment between its entry and
/// exit face planes (clip planes and the eye cut it) looked up in the table and composited front to back, with
/// early termination, as pt_raster does. Output channels R, G, B, A.
ImageBuffer ptMirrorRender(const PtMirrorInput& in);

} // namespace volcl
