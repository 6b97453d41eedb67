// Opens a scene's data (a grid or a tetrahedral mesh) and makes its renderer.
#include "host/render/RenderInput.hpp"

#include "host/Volume.hpp"
#include "host/render/grid/GridDetail.hpp"
#include "host/render/grid/GridRenderer.hpp"
#include "host/Error.hpp"
#include "host/render/mesh/MeshReference.hpp"
#include "host/render/mesh/MeshRenderer.hpp"
#include "host/render/mesh/KBufferRenderer.hpp"

namespace volcl {

RenderInput::RenderInput(std::shared_ptr<const Volume> volume) : volume_(std::move(volume)) {}

RenderInput::RenderInput(std::shared_ptr<const mesh::TetMesh> mesh) : mesh_(std::move(mesh)) {}

RenderInput RenderInput::open(const std::filesystem::path& path, const ReadOptions& options,
                              const mesh::MeshReadOptions& meshOptions) {
    if (mesh::detectMeshFormat(path)) return fromMesh(mesh::readMesh(path, meshOptions));
    return fromVolume(readVolume(path, options));
}

RenderInput RenderInput::fromMesh(mesh::TetMesh mesh) {
    return RenderInput(std::make_shared<const mesh::TetMesh>(std::move(mesh)));
}

RenderInput RenderInput::borrowMesh(const mesh::TetMesh& mesh) {
    return RenderInput(std::shared_ptr<const mesh::TetMesh>(&mesh, [](const mesh::TetMesh*) {}));
}

RenderInput RenderInput::fromVolume(Volume volume) {
    return RenderInput(std::make_shared<const Volume>(std::move(volume)));
}

RenderInput RenderInput::borrow(const Volume& volume) {
    return RenderInput(std::shared_ptr<const Volume>(&volume, [](const Volume*) {}));
}

WorldBox RenderInput::bounds() const {
    if (mesh_) return meshBounds(*mesh_);
    return gridBounds(*volume_);
}

ValueRange RenderInput::valueRange() const {
    if (mesh_) return meshValueRange(*mesh_);
    return grid_detail::valueRange(*volume_);
}

std::string RenderInput::summary() const {
    if (mesh_) return std::to_string(mesh_->tetCount()) + " tets, " + std::to_string(mesh_->pointCount()) + " points";
    const Dims& d = volume_->dims();
    return std::to_string(d.x) + "x" + std::to_string(d.y) + "x" + std::to_string(d.z) + " " +
           std::string(scalarTypeName(volume_->type()));
}

EffectPlan RenderInput::planEffects(const Scene& scene, const TransferFunction& tf) const {
    if (mesh_ && scene.meshMethod == MeshMethod::KBuffer) // no device here: the plan as on a CPU device
        return planKBuffer(scene, *mesh_, scene.kBufferDepth, true);
    if (mesh_) return planMeshEffects(scene, *mesh_);
    return volcl::planEffects(scene, *volume_, tf);
}

ImageBuffer RenderInput::renderReference(const TransferFunction& tf, const Scene& scene,
                                         const ReferenceOptions& options) const {
    if (mesh_) return meshReferenceRender(*mesh_, tf, scene, options);
    return referenceRender(*volume_, tf, scene, options);
}

std::unique_ptr<VolumeRenderer> RenderInput::makeRenderer(ComputeContext& cc, const TransferFunction& tf,
                                                          const Scene& scene) const {
    if (mesh_) {
        if (scene.meshMethod == MeshMethod::KBuffer) return makeKBufferRenderer(cc, *mesh_, tf, scene);
        return std::make_unique<MeshRenderer>(cc, *mesh_, tf, scene);
    }
    return std::make_unique<GridRenderer>(cc, *volume_, tf, scene);
}

} // namespace volcl
