// Opens a scene's data and makes its renderer: grids, and frames of compressed-brick .vcz files.
#include "host/render/RenderInput.hpp"

#include "host/Volume.hpp"
#include "host/render/grid/GridDetail.hpp"
#include "host/render/grid/GridRenderer.hpp"
#include "host/render/bricks/BrickRenderer.hpp"
#include "host/io/AtomicFile.hpp"
#include "wavelet/Codec.hpp"

#include "host/Error.hpp"

#include <algorithm>
#include <limits>

namespace volcl {

RenderInput::RenderInput(std::shared_ptr<const Volume> volume) : volume_(std::move(volume)) {}

RenderInput RenderInput::open(const std::filesystem::path& path, const ReadOptions& options) {
    if (path.extension() == ".vcz") return openVcz(path, 0);
    return fromVolume(readVolume(path, options));
}

RenderInput RenderInput::openVcz(const std::filesystem::path& path, std::size_t frame) {
    RenderInput in(nullptr);
    in.vcz_ = std::make_shared<const VczReader>(readFileBytes(path), path.string());
    if (frame >= in.vcz_->header().frames.size())
        throw UsageError("--frame " + std::to_string(frame) + " out of range: " + path.string() + " has " +
                         std::to_string(in.vcz_->header().frames.size()) + " frame(s)");
    in.frame_ = frame;
    return in;
}

RenderInput RenderInput::fromVolume(Volume volume) {
    return RenderInput(std::make_shared<const Volume>(std::move(volume)));
}

RenderInput RenderInput::borrow(const Volume& volume) {
    return RenderInput(std::shared_ptr<const Volume>(&volume, [](const Volume*) {}));
}

WorldBox RenderInput::bounds() const {
    if (vcz_) {
        const VczHeader& h = vcz_->header();
        return {h.origin, {double(h.dims.x - 1) * h.spacing[0], double(h.dims.y - 1) * h.spacing[1],
                           double(h.dims.z - 1) * h.spacing[2]}};
    }
    return gridBounds(*volume_);
}

ValueRange RenderInput::valueRange() const {
    if (vcz_) {
        ValueRange r{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
        for (const VczBrickEntry& e : vcz_->header().bricks[frame_]) {
            r.min = std::min(r.min, e.min);
            r.max = std::max(r.max, e.max);
        }
        return r;
    }
    return grid_detail::valueRange(*volume_);
}

std::string RenderInput::summary() const {
    if (vcz_) {
        const VczHeader& h = vcz_->header();
        return std::to_string(h.dims.x) + "x" + std::to_string(h.dims.y) + "x" + std::to_string(h.dims.z) + " " +
               std::string(scalarTypeName(h.type)) + ", " + std::to_string(h.brickCount()) + " compressed bricks";
    }
    const Dims& d = volume_->dims();
    return std::to_string(d.x) + "x" + std::to_string(d.y) + "x" + std::to_string(d.z) + " " +
           std::string(scalarTypeName(volume_->type()));
}

EffectPlan RenderInput::planEffects(const Scene& scene, const TransferFunction& tf) const {
    if (vcz_) {
        EffectPlan p = volcl::planEffects(scene, bounds(), valueRange(), "macrocells over the brick index");
        p.defines.set("VOXEL_TYPE", 0LL);
        return p;
    }
    return volcl::planEffects(scene, *volume_, tf);
}

ImageBuffer RenderInput::renderReference(const TransferFunction& tf, const Scene& scene,
                                         const ReferenceOptions& options) const {
    if (vcz_)
        throw UsageError(vcz_->name() + ": the double reference renders grids: decode the file first (volcl decode)");
    return referenceRender(*volume_, tf, scene, options);
}

std::unique_ptr<VolumeRenderer> RenderInput::makeRenderer(ComputeContext& cc, const TransferFunction& tf,
                                                          const Scene& scene) const {
    if (vcz_) return std::make_unique<BrickRenderer>(cc, vcz_, frame_, tf, scene);
    return std::make_unique<GridRenderer>(cc, *volume_, tf, scene);
}

} // namespace volcl
