// The exact cell ray caster of tetrahedral meshes with OpenCL (render.method "cells"): cl/mesh/mesh_cells.cl.
#pragma once

#include "cl/volcl_shared.h"
#include "host/mesh/TetMesh.hpp"
#include "render/EffectPlan.hpp"
#include "render/RendererBase.hpp"

#include <memory>

namespace volcl {

/// The planned clip planes in a mesh's normalised frame x' = (x - centre) / scale (unit normals; the kernels
/// keep n.x' + w >= 0).
VolclClipParams meshClipParams(const std::vector<ClipPlane>& planes, const Vec3& centre, double scale);

/// Renders scenes of a tetrahedral mesh by walking each pixel's ray through face-adjacent tets. Keeps the
/// mesh on the device in a normalised frame (centre at 0, bounding radius 1) as per-tet face planes, linear
/// fields and neighbours, with a BVH of the boundary faces for the entries; the TF, the per-tet emptiness and
/// the 3D pre-integration table (lengths up to the longest edge) are rebuilt only when they change. The mesh
/// must outlive the renderer. Example:
/// ```
/// volcl::mesh::TetMesh m = volcl::mesh::readMesh("bluntfinxyz.bin");
/// volcl::MeshRenderer r(cc, m, tf, scene);
/// volcl::ImageBuffer img = r.render();
/// ```
class MeshRenderer final : public RendererBase {
public:
    /// Throws UsageError for an invalid scene, DataError for an invalid TF or an empty mesh.
    MeshRenderer(ComputeContext& cc, const mesh::TetMesh& mesh, const TransferFunction& tf,
                 const Scene& scene);
    ~MeshRenderer() override;

    EffectPlan planEffects(const Scene& scene) const override;
    ImageBuffer render() override;
    /// "tets: N, boundary faces: B (BVH of K nodes), x% of tets empty under the TF".
    std::string statistics() const override;

private:
    struct Impl;
    void rebuild(const Rebuild& change) override;
    void viewChanged(bool sameView) override;
    /// Integral of tau from knot 0 to each knot, for xray (after the knots changed).
    void uploadTauIntegral();
    /// The smooth normals' per-tet fields (once per renderer).
    void uploadNormals();
    /// Per-tet emptiness under the shaded TF and the iso-values.
    void updateEmptiness(const TransferFunction& shaded, bool preint);
    /// The kernel's parameter block in the normalised frame.
    void updateParams(const TransferFunction& shaded);
    const mesh::TetMesh& mesh_;
    std::unique_ptr<Impl> impl_;
    double emptyFraction_ = 0.0;
};

} // namespace volcl
