// The k-buffer mesh renderer (HAVS, Callahan 2005): unique faces ordered every frame (placed by an exact
// visibility order of the cells, or sorted by centroid on the device), rasterised in that order into per-pixel
// k-buffers that composite segments through a 3D pre-integration table.
#pragma once

#include "host/mesh/TetMesh.hpp"
#include "render/RendererBase.hpp"
#include "render/mesh/KBufferFrame.hpp"
#include "render/mesh/KBufferOrder.hpp"
#include "render/mesh/MeshFaces.hpp"
#include "render/mesh/VisibilitySort.hpp"

#include <memory>
#include <string>

namespace volcl {

/// Times of the last frame's stages, milliseconds: kernels by profiling events; with an exact order (render.sort
/// "mpvo" or "convexified") `sort` is the host's cell sort and `place` the host's face placement plus the
/// order's upload; with "centroid" `sort` is the device radix sort's kernels and `place` 0.
struct KBufferStageTimes {
    double project = 0, keys = 0, sort = 0, place = 0, bin = 0, raster = 0;
    double total() const noexcept { return project + keys + sort + place + bin + raster; }
};

/// Which long faces are cut before rendering with the centroid sort (splitLongFaces; an exact order needs no
/// cuts): faces longer than `ratio` times the median face, adding at most `budget` times the face count;
/// ratio 0 cuts none. The default leaves a uniform mesh
/// (the generated grids) untouched and brings the O-grid of the LOx post to RMSE 0.01 at k = 6 (0.035 uncut),
/// at about twice the frame time there; docs/meshes.md has the sweep.
struct FaceSplitOptions {
    double ratio = 1.5;
    double budget = 3.0;
};

/// Renders a tetrahedral mesh with the k-buffer (render.method "kbuffer"): per frame the drawn faces are put
/// in order by render.sort (unset: defaultKBufferSort): "mpvo" / "convexified" sort the cells back to front on
/// the host (VisibilitySorter) and place each face with the nearer of its tets (KBufferFaceSorter), so
/// fragments arrive in ray order wherever the cell order is exact; "centroid"
/// gives each face a centroid key (view depth, or distance to the eye in perspective) and a device radix sort
/// orders them. A stable binning puts each into the 16x16-pixel screen tiles it touches (keeping the order) and one
/// work-group per tile rasterises its faces into k-entry per-pixel buffers in local memory. A full buffer
/// pops its nearest fragment and composites the segment to the second nearest (linear scalar between the
/// two fragments' values, their distance as length) through the 3D table; boundary faces mark where rays
/// enter and leave, so gaps of non-convex meshes stay empty. Fragments more than k places out of order are
/// composited out of order: the error a too small k costs with the centroid order, measured in docs/meshes.md.
///
/// Level of detail: setLodFraction(q) draws the boundary faces and the first q of the importance-ordered
/// internal faces (MeshFaces), with a table over the box diagonal since segments then span several tets;
/// q = 1 is full quality. Modes dvr and iso (Callahan's App. B: each popped segment composites the iso-surfaces
/// its linear scalar crosses, lit with smooth vertex normals); other modes and effects are refused or dropped by
/// planEffects().
/// The mesh must outlive the renderer. Example:
/// ```
/// volcl::KBufferRenderer r(cc, mesh, tf, scene, 6);
/// volcl::ImageBuffer img = r.render();
/// r.setLodFraction(0.1);              // interactive frame: boundary + 10 % of the internal faces
/// ```
class KBufferRenderer final : public RendererBase {
public:
    /// Throws UsageError for k outside 2..8 or a scene the method cannot draw (modes other than dvr and iso).
    KBufferRenderer(ComputeContext& cc, const mesh::TetMesh& mesh, const TransferFunction& tf,
                    const Scene& scene, int k = kKBufferDefaultK, const FaceSplitOptions& split = {});
    ~KBufferRenderer() override;

    EffectPlan planEffects(const Scene& scene) const override;
    /// lastKernelMilliseconds(): the total of lastStageTimes().
    ImageBuffer render() override;
    /// "faces: 2 boundary + 3 internal, drawn 5, k 6, sort mpvo (cells 0.1 ms, cycles broken 0, faces placed
    /// 0.1 ms), tile entries 9" (the parenthesis with an exact order only).
    std::string statistics() const override;

    int k() const noexcept { return k_; }
    /// The face order of the frames (render.sort; unset: defaultKBufferSort of the mesh).
    MeshSort sortMethod() const noexcept { return sort_; }
    void setK(int k);
    /// Fraction of the internal faces drawn, [0, 1] (1: full quality, the default).
    void setLodFraction(double q);
    std::size_t facesDrawn() const noexcept;
    const MeshFaces& faces() const noexcept { return faces_; }
    const KBufferStageTimes& lastStageTimes() const noexcept { return times_; }

    /// What the C++ mirror (kbufferMirrorRender) needs to reproduce the next frame exactly.
    const KBufferGeometry& geometry() const noexcept { return geometry_; }
    VolclKBufferParams frameParams() const;
    /// The table the next frame reads (float RGBA, PreintegrationTable layout), its values rounded to half
    /// precision as the device holds them.
    const std::vector<float>& tableValues() const;
    /// Mode iso: the planned iso-surfaces and the lights in the normalized frame, and (with shading) the point
    /// normals the frame lights with (empty without shading).
    VolclIsoParams isoFrameParams() const;
    VolclLightingParams lightFrameParams() const;
    const std::vector<cl_float4>& pointNormals() const;
    /// The device's face order of the last frame (downloaded; for tests).
    std::vector<cl_uint> lastOrder();
    /// The face order the last frame took from the host (exact sorts; what the C++ mirror must draw in), or
    /// null when the device sorted by centroid.
    const std::vector<std::uint32_t>* hostOrder() const noexcept;
    /// Visibility cycles the last frame's cell sort broke (0 with "centroid" or an exact order).
    std::size_t lastCyclesBroken() const noexcept { return cyclesBroken_; }

private:
    struct Impl;
    struct Table;
    /// Takes a new render.k (an unchanged one keeps the k this renderer was made or set with) and refuses
    /// what the method cannot draw.
    void admitScene(const Scene& next) override;
    void rebuild(const Rebuild& change) override;
    /// Frames do not depend on render.step: every segment goes through the 3D table.
    bool stepNeedsRebuild() const override { return false; }
    /// render.sort of a scene, unset: defaultKBufferSort (found once).
    MeshSort sortOf(const Scene& scene) const;
    /// Builds the faces and their device buffers for the current order (long faces cut for the centroid sort
    /// only) unless they are built so already.
    void ensureFaces();
    /// Makes the table of the current level of detail current, from the cache or built.
    void ensureTable();
    Table buildTable(const TableSpec& spec);
    const mesh::TetMesh& mesh_;
    FaceSplitOptions split_;
    bool facesBuilt_ = false, facesCut_ = false;
    MeshFaces faces_;
    KBufferGeometry geometry_;
    int k_;
    MeshSort sort_ = MeshSort::Centroid;
    std::size_t cyclesBroken_ = 0;
    double lod_ = 1.0;
    std::unique_ptr<Impl> impl_;
    KBufferStageTimes times_;
};

/// The renderer for render.method "kbuffer" (RenderInput::makeRenderer calls it): a KBufferRenderer of depth
/// scene.kBufferDepth. `mesh` must outlive it.
std::unique_ptr<VolumeRenderer> makeKBufferRenderer(ComputeContext& cc, const mesh::TetMesh& mesh,
                                                    const TransferFunction& tf, const Scene& scene);

/// The plan of the k-buffer method for a scene on a device of this profile, its faces ordered by `sort`: the
/// defines its kernels compile with and what it drops (dvr: shading, clipping, iso-surfaces; iso: clipping,
/// flat normals). Throws UsageError for modes other than dvr and iso.
EffectPlan planKBuffer(const Scene& scene, const mesh::TetMesh& mesh, int k, const DeviceProfile& device,
                       MeshSort sort);

} // namespace volcl
