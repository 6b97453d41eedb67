// The C++ mirror of the k-buffer kernels (cl/mesh/mesh_kbuffer.cl): the same float arithmetic, face order and
// per-pixel k-buffer, to test the OpenCL path fragment for fragment.
#pragma once

#include "host/image/ImageIo.hpp"
#include "render/mesh/KBufferFrame.hpp"
#include "render/mesh/MeshFaces.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace volcl {

/// The mirror also runs deeper buffers than the kernels (2..8): with k larger than any pixel's fragment count
/// it is an A-buffer with the exact per-pixel order, the limit the k-buffer converges to.
inline constexpr int kKBufferMirrorMaxK = 4096;

/// Inputs of one mirrored frame: the renderer's normalized points, the point scalars, the faces with the
/// number drawn (params.faceCount), the frame parameters, the table with the values the device holds (rounded
/// to half precision; as float RGBA in PreintegrationTable's layout: the mirror does not mirror the blocking)
/// and k.
struct KBufferMirrorInput {
    const KBufferGeometry* geometry = nullptr;
    const std::vector<float>* scalars = nullptr;
    const MeshFaces* faces = nullptr;
    VolclKBufferParams params{};
    const std::vector<float>* table = nullptr;
    int k = kKBufferDefaultK;
    /// The frame's face order when the host made it (KBufferRenderer::hostOrder: an exact visibility order,
    /// indices into faces, params.faceCount of them); null: the centroid order (kbufferMirrorOrder).
    const std::vector<std::uint32_t>* order = nullptr;
    /// The NaN colour (straight r, g, b and extinction tau) of segments with a non-finite end (NAN_COLOR).
    std::array<float, 4> nanColor{0, 0, 0, 0};
    /// Mode iso (KB_ISO): segments composite the iso-surfaces they cross instead of the table; with `shading`,
    /// lit by `lighting` (normalized frame) with the point normals `normals` (kbufferPointNormals).
    bool iso = false;
    bool shading = false;
    VolclIsoParams isoParams{};
    VolclLightingParams lighting{};
    const std::vector<cl_float4>* normals = nullptr;
};

/// What the mirror counted besides the image.
struct KBufferMirrorStats {
    std::size_t fragments = 0;      ///< pixel-face intersections inserted
    std::size_t pixelTests = 0;     ///< pixels of face rectangles tested against a face's edges
    std::size_t overflowPops = 0;   ///< pops made while inserting (a full k-buffer)
    std::size_t misorderedPops = 0; ///< pops nearer than the pixel's previous pop: k was too small there
};

/// A point as kb_project places it: screen x and y (pixel centres at integers), view depth z and 1 / z (w = 0:
/// a perspective point at or behind the near distance).
struct KBufferProjected {
    float x, y, z, w;
};
/// kb_project of the normalized point p, in the same float operations.
KBufferProjected kbufferMirrorProject(const cl_float4& p, const VolclKBufferParams& P);
/// The 3D table lookup of the k-buffer kernels (tf_lookup.h's preint_segment for PREINT 3 with the frame's
/// factors precomputed) on a float table in PreintegrationTable's layout: associated (rgb, alpha) of the segment
/// sf -> sb of length len.
std::array<float, 4> kbufferMirrorPreint(const std::vector<float>& table, const VolclKBufferParams& P,
                                         float sf, float sb, float len);

/// The frame on the host: projection, the face order (in.order, else centroid keys and a stable sort: the
/// radix sort's order), every face
/// rasterised over its pixel rectangle in that order with the kernel's edge and tie rules, k-buffer insert,
/// pop and flush, table lookups (or iso-surface crossings, lit as cl/common/shading.h lights them) and
/// compositing as the kernel does them. Output channels R, G, B, A.
ImageBuffer kbufferMirrorRender(const KBufferMirrorInput& in, KBufferMirrorStats* stats = nullptr);

/// The face order of a frame (indices into in.faces, the first params.faceCount faces, by centroid key,
/// stable): what the device radix sort must produce.
std::vector<std::uint32_t> kbufferMirrorOrder(const KBufferMirrorInput& in);

} // namespace volcl
