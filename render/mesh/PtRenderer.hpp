// Projected tetrahedra (render.method "pt"): cells in a visibility order from the host, composited per screen tile
// on the device through the 3D pre-integration table.
#pragma once

#include "host/mesh/TetMesh.hpp"
#include "render/RendererBase.hpp"
#include "render/mesh/KBufferFrame.hpp"
#include "render/mesh/VisibilitySort.hpp"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace volcl {

/// Kernel times of the last pt frame's stages (profiling events), milliseconds, and the host sort's time.
struct PtStageTimes {
    double sort = 0, project = 0, bin = 0, raster = 0; ///< sort: host seconds x 1000 (not a kernel)
    double kernels() const noexcept { return project + bin + raster; }
};

/// Renders a tetrahedral mesh by projected tetrahedra (render.method "pt"). Each frame the host orders the cells
/// back to front (VisibilitySorter, render.sort) and uploads the order; on the device the mesh points are
/// projected (the k-buffer's kb_project), every cell in order gets the rectangle of screen tiles its projection
/// touches, the k-buffer's stable binning appends it to those tiles' lists keeping the order, and one work-group
/// per 16x16-pixel tile walks its list from the nearest cell to the farthest: at each pixel of the cell's
/// rectangle the ray's segment between the cell's entry and exit face planes (the per-pixel form of
/// Shirley-Tuchman's thick ray segments), its scalar linear from s_front to s_back, is looked up in the 3D
/// pre-integration table the cell caster uses (s_front, s_back, length) and composited front to back. With an
/// exact order the image is the cell caster's; a wrong order composites overlapping cells in the wrong order.
///
/// Draws mode dvr with clip planes (segments cut at the planes), early termination and NaN cells; shading and
/// iso-surfaces are refused (UsageError naming the feature), other modes too. A camera inside the mesh is
/// handled: segments start at the eye (cells behind it cover nothing). The mesh must outlive the renderer.
/// ```
/// volcl::PtRenderer r(cc, mesh, tf, scene);     // scene.meshSort: centroid, mpvo or convexified
/// volcl::ImageBuffer img = r.render();
/// ```
class PtRenderer final : public RendererBase {
public:
    /// Throws UsageError for a scene the method cannot draw, DataError for an empty mesh.
    PtRenderer(ComputeContext& cc, const mesh::TetMesh& mesh, const TransferFunction& tf, const Scene& scene);
    ~PtRenderer() override;

    EffectPlan planEffects(const Scene& scene) const override;
    ImageBuffer render() override;
    /// "tets: N, sort convexified (cycles broken 0, 12.3 ms), tile entries E".
    std::string statistics() const override;

    MeshSort sortMethod() const noexcept { return sort_; }
    const PtStageTimes& lastStageTimes() const noexcept { return times_; }
    /// The order the last frame composited (farthest first) and its cycle count.
    const VisibilityOrder& lastOrder() const noexcept { return order_; }
    /// What the C++ mirror (ptMirrorRender) needs for the next frame: the normalised geometry, its parameters
    /// (camera, image, tiles, table geometry), the normalised clip planes and the table's values (float RGBA,
    /// PreintegrationTable layout, downloaded).
    const KBufferGeometry& geometry() const noexcept { return geometry_; }
    VolclKBufferParams frameParams() const;
    VolclClipParams normalisedClip() const;
    std::vector<float> tableValues();

private:
    struct Impl;
    void admitScene(const Scene& next) override;
    void rebuild(const Rebuild& change) override;
    /// Frames do not depend on render.step: every segment goes through the 3D table.
    bool stepNeedsRebuild() const override { return false; }
    const mesh::TetMesh& mesh_;
    KBufferGeometry geometry_;
    MeshSort sort_ = MeshSort::Convexified;
    VisibilityOrder order_;
    std::unique_ptr<Impl> impl_;
    PtStageTimes times_;
};

/// The plan of the pt method: mode dvr through the 3D table, clip planes, early termination, NaN cells. Throws
/// UsageError for other modes, shading and iso-surfaces; lists render.preintegration other than 3d and empty-space
/// skipping as dropped.
EffectPlan planPt(const Scene& scene, const mesh::TetMesh& mesh, const DeviceProfile& device);

/// The sort a scene asks for (render.sort; unset: defaultMeshSort, mpvo for a convex mesh, else convexified).
MeshSort sceneMeshSort(const Scene& scene, const mesh::TetMesh& mesh);

/// The viewpoint of a camera as a visibility sort needs it (world coordinates).
SortView sortViewOf(const Camera& camera);

} // namespace volcl
