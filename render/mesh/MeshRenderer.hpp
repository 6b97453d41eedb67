// The exact cell ray caster of tetrahedral meshes with OpenCL (render.method "cells"): cl/mesh/mesh_cells.cl.
#pragma once

#include "host/mesh/TetMesh.hpp"
#include "render/VolumeRenderer.hpp"

#include <memory>

namespace volcl {

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
class MeshRenderer final : public VolumeRenderer {
public:
    /// Throws UsageError for an invalid scene, DataError for an invalid TF or an empty mesh.
    MeshRenderer(ComputeContext& cc, const mesh::TetMesh& mesh, const TransferFunction& tf,
                 const Scene& scene);
    ~MeshRenderer() override;
    MeshRenderer(const MeshRenderer&) = delete;
    MeshRenderer& operator=(const MeshRenderer&) = delete;

    WorldBox bounds() const override;
    ValueRange valueRange() const override;
    EffectPlan planEffects(const Scene& scene) const override;

    void setScene(const Scene& scene) override;
    void setTransferFunction(const TransferFunction& tf) override;
    void setView(const Camera& camera, int width, int height, double step) override;
    ImageBuffer render() override;

    const cl::Buffer& outputBuffer() const noexcept override;
    const EffectPlan& plan() const noexcept override { return plan_; }
    const Scene& scene() const noexcept override { return scene_; }
    const Camera& camera() const noexcept override { return camera_; }
    double lastKernelMilliseconds() const noexcept override { return lastMs_; }
    double lastTableMilliseconds() const noexcept override { return tableMs_; }
    /// "tets: N, boundary faces: B (BVH of K nodes), x% of tets empty under the TF".
    std::string statistics() const override;

private:
    struct Impl;
    void rebuild(bool tfChanged);
    void updateViewParams();
    ComputeContext& cc_;
    const mesh::TetMesh& mesh_;
    TransferFunction tf_;
    Scene scene_;
    Camera camera_;
    EffectPlan plan_;
    std::unique_ptr<Impl> impl_;
    double lastMs_ = 0.0, tableMs_ = 0.0, emptyFraction_ = 0.0;
};

} // namespace volcl
