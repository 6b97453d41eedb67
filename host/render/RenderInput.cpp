// Opens a scene's data and makes its renderer (grids today).
#include "host/render/RenderInput.hpp"

#include "host/Volume.hpp"
#include "host/render/grid/GridDetail.hpp"
#include "host/render/grid/GridRenderer.hpp"

namespace volcl {

RenderInput::RenderInput(std::shared_ptr<const Volume> volume) : volume_(std::move(volume)) {}

RenderInput RenderInput::open(const std::filesystem::path& path, const ReadOptions& options) {
    return fromVolume(readVolume(path, options));
}

RenderInput RenderInput::fromVolume(Volume volume) {
    return RenderInput(std::make_shared<const Volume>(std::move(volume)));
}

RenderInput RenderInput::borrow(const Volume& volume) {
    return RenderInput(std::shared_ptr<const Volume>(&volume, [](const Volume*) {}));
}

WorldBox RenderInput::bounds() const {
    return gridBounds(*volume_);
}

ValueRange RenderInput::valueRange() const {
    return grid_detail::valueRange(*volume_);
}

std::string RenderInput::summary() const {
    const Dims& d = volume_->dims();
    return std::to_string(d.x) + "x" + std::to_string(d.y) + "x" + std::to_string(d.z) + " " +
           std::string(scalarTypeName(volume_->type()));
}

EffectPlan RenderInput::planEffects(const Scene& scene, const TransferFunction& tf) const {
    return volcl::planEffects(scene, *volume_, tf);
}

ImageBuffer RenderInput::renderReference(const TransferFunction& tf, const Scene& scene,
                                         const ReferenceOptions& options) const {
    return referenceRender(*volume_, tf, scene, options);
}

std::unique_ptr<VolumeRenderer> RenderInput::makeRenderer(ComputeContext& cc, const TransferFunction& tf,
                                                          const Scene& scene) const {
    return std::make_unique<GridRenderer>(cc, *volume_, tf, scene);
}

} // namespace volcl
