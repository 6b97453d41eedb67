// Opens a scene's data (a grid, a frame of a compressed-brick .vcz, or a tetrahedral mesh) and makes its renderer.
#include "render/RenderInput.hpp"

#include "core/AtomicFile.hpp"
#include "core/Volume.hpp"
#include "meshcodec/MeshCodec.hpp"
#include "render/VecMath.hpp"
#include "render/bricks/BrickRenderer.hpp"
#include "render/grid/GridDetail.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/grid/PreviewRenderer.hpp"
#include "render/grid/PreviewTiers.hpp"
#include "render/mesh/KBufferRenderer.hpp"
#include "render/mesh/MeshReference.hpp"
#include "render/mesh/MeshRenderer.hpp"
#include "render/mesh/PtRenderer.hpp"
#include "wavelet/Codec.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl {

Volume kernelVoxels(Volume v) {
    // OpenCL 1.2 does not guarantee doubles (cl_khr_fp64 is optional): the kernels sample float32.
    return v.type() == ScalarType::Float64 ? v.convertedTo(ScalarType::Float32) : v;
}

namespace {
std::shared_ptr<const Volume> kernelGrid(std::shared_ptr<const Volume> v) {
    if (!v || v->type() != ScalarType::Float64) return v;
    return std::make_shared<const Volume>(kernelVoxels(*v));
}
} // namespace

RenderInput::RenderInput(std::shared_ptr<const Volume> volume) : volume_(kernelGrid(std::move(volume))) {}

RenderInput::RenderInput(std::shared_ptr<const mesh::TetMesh> mesh) : mesh_(std::move(mesh)) {}

RenderInput RenderInput::open(const std::filesystem::path& path, const ReadOptions& options,
                              const mesh::MeshReadOptions& meshOptions) {
    if (path.extension() == ".vcz") return openVcz(path, 0);
    if (meshcodec::isMeshFile(path)) return openMesh(path, meshOptions);
    return fromVolume(readVolume(path, options));
}

RenderInput RenderInput::openMesh(const std::filesystem::path& path,
                                  const mesh::MeshReadOptions& meshOptions) {
    mesh::TetMesh m = meshcodec::readAnyMesh(path, meshOptions);
    const std::size_t folded = m.repairs.overlappingFaces + m.repairs.nonManifoldFaces;
    if (folded > kFoldedFacesAlways && double(folded) > kMaxFoldedFaceShare * double(m.tets.size()))
        throw DataError(
            path.string() + ": " + std::to_string(folded) + " faces of its " + std::to_string(m.tets.size()) +
            " tets are folded (overlapping or non-manifold), more than 10%: not a tetrahedral mesh "
            "the cell caster can trace in bounded time (are its points out of order?)");
    return fromMesh(std::move(m));
}

RenderInput RenderInput::fromMesh(mesh::TetMesh mesh) {
    return RenderInput(std::make_shared<const mesh::TetMesh>(std::move(mesh)));
}

RenderInput RenderInput::borrowMesh(const mesh::TetMesh& mesh) {
    return RenderInput(std::shared_ptr<const mesh::TetMesh>(&mesh, [](const mesh::TetMesh*) {}));
}

RenderInput RenderInput::openVcz(const std::filesystem::path& path, std::size_t frame) {
    RenderInput in(std::shared_ptr<const Volume>{});
    in.vcz_ = std::make_shared<const VczReader>(path); // mapped: bricks are read as they are decoded
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
        return {h.origin,
                {double(h.dims.x - 1) * h.spacing[0], double(h.dims.y - 1) * h.spacing[1],
                 double(h.dims.z - 1) * h.spacing[2]}};
    }
    if (mesh_) return meshBounds(*mesh_);
    return gridBounds(*volume_);
}

double RenderInput::cellLength() const {
    if (mesh_) return approximateCellLength();
    const std::array<double, 3> sp = vcz_ ? vcz_->header().spacing : volume_->spacing;
    return std::min({sp[0], sp[1], sp[2]});
}

double RenderInput::approximateCellLength() const {
    double cells = 1.0;
    if (mesh_) {
        cells = double(std::max<std::size_t>(mesh_->tetCount(), 1));
    } else {
        const Dims d = vcz_ ? vcz_->header().dims : volume_->dims();
        cells = double(std::max<std::int64_t>(d.x - 1, 1)) * double(std::max<std::int64_t>(d.y - 1, 1)) *
                double(std::max<std::int64_t>(d.z - 1, 1));
    }
    const double diagonal = norm(bounds().extent);
    return diagonal > 0.0 ? diagonal / std::cbrt(cells) : 1.0;
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
    if (mesh_) return meshValueRange(*mesh_);
    return grid_detail::valueRange(*volume_);
}

std::string RenderInput::summary() const {
    if (vcz_) {
        const VczHeader& h = vcz_->header();
        return std::to_string(h.dims.x) + "x" + std::to_string(h.dims.y) + "x" + std::to_string(h.dims.z) +
               " " + std::string(scalarTypeName(h.type)) + ", " + std::to_string(h.brickCount()) +
               " compressed bricks";
    }
    if (mesh_)
        return std::to_string(mesh_->tetCount()) + " tets, " + std::to_string(mesh_->pointCount()) +
               " points";
    const Dims& d = volume_->dims();
    return std::to_string(d.x) + "x" + std::to_string(d.y) + "x" + std::to_string(d.z) + " " +
           std::string(scalarTypeName(volume_->type()));
}

EffectPlan RenderInput::planEffects(const Scene& sceneAsGiven, const TransferFunction& tf) const {
    const Scene scene = resolved(sceneAsGiven);
    if (vcz_) {
        EffectPlan p = volcl::planEffects(scene, bounds(), valueRange(), "macrocells over the brick index");
        p.defines.set("VOXEL_TYPE", 0LL);
        planNanColor(scene, !vczNonFiniteBricks(vcz_->header(), frame_).empty(), p);
        planGradientTf(tf, p);
        return p;
    }
    if (mesh_ && scene.meshMethod != MeshMethod::Cells) { // no device here: the plan as on a CPU device
        DeviceInfo cpu;
        cpu.isCpu = true;
        if (scene.meshMethod == MeshMethod::ProjectedTetrahedra)
            return planPt(scene, *mesh_, deviceProfileFor(cpu));
        return planKBuffer(scene, *mesh_, scene.kBufferDepth, deviceProfileFor(cpu),
                           scene.meshSort ? *scene.meshSort : defaultKBufferSort(*mesh_));
    }
    if (mesh_) return planMeshEffects(scene, *mesh_);
    EffectPlan p = volcl::planEffects(scene, *volume_, tf);
    planGradientTf(tf, p);
    return p;
}

ImageBuffer RenderInput::renderReference(const TransferFunction& tf, const Scene& sceneAsGiven,
                                         const ReferenceOptions& options) const {
    const Scene scene = resolved(sceneAsGiven);
    if (vcz_)
        throw UsageError(vcz_->name() +
                         ": the double reference renders grids: decode the file first (volcl decode)");
    if (mesh_) return meshReferenceRender(*mesh_, tf, scene, options);
    return referenceRender(*volume_, tf, scene, options);
}

Scene RenderInput::resolved(const Scene& scene) const {
    const bool cropInVoxels = scene.effects.cropBox && scene.effects.cropBox->voxels;
    if (!scene.stepVoxels && !cropInVoxels) return scene;
    Scene s = scene;
    resolveStep(s, cellLength());
    resolveCropBox(s);
    return s;
}

std::string RenderInput::resolveCropBox(Scene& scene) const {
    if (!scene.effects.cropBox || !scene.effects.cropBox->voxels) return {};
    if (mesh_)
        throw UsageError(
            "effects.crop_box in voxels: a mesh has no voxel grid (give the box in world units)");
    const VczHeader* h = vcz_ ? &vcz_->header() : nullptr;
    const std::array<double, 3> origin = h ? h->origin : volume_->origin;
    const std::array<double, 3> spacing = h ? h->spacing : volume_->spacing;
    return volcl::resolveCropBox(scene, origin, spacing);
}

std::unique_ptr<VolumeRenderer> RenderInput::makeRenderer(ComputeContext& cc, const TransferFunction& tf,
                                                          const Scene& sceneAsGiven) const {
    const Scene scene = resolved(sceneAsGiven);
    if (scene.gridMethod != GridMethod::Raymarch && !volume_)
        throw UsageError("render.method " + std::string(gridMethodName(scene.gridMethod)) +
                         " renders grids only (" +
                         (vcz_ ? "decode the .vcz first" : "meshes take cells or kbuffer") + ")");
    if (vcz_) return std::make_unique<BrickRenderer>(cc, vcz_, frame_, tf, scene);
    if (mesh_) {
        if (scene.meshMethod == MeshMethod::KBuffer) return makeKBufferRenderer(cc, *mesh_, tf, scene);
        if (scene.meshMethod == MeshMethod::ProjectedTetrahedra)
            return std::make_unique<PtRenderer>(cc, *mesh_, tf, scene);
        return std::make_unique<MeshRenderer>(cc, *mesh_, tf, scene);
    }
    if (scene.gridMethod != GridMethod::Raymarch)
        return std::make_unique<GridPreviewRenderer>(cc, *volume_, tf, scene);
    return std::make_unique<GridRenderer>(cc, *volume_, tf, scene);
}

} // namespace volcl
