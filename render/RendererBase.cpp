// The renderers' shared part: commit and validation of scenes, TFs and views, re-planning, knots, tables,
// frame buffers and the image read-back.
#include "render/RendererBase.hpp"

#include "core/Format.hpp"
#include "render/VecMath.hpp"

#include <cstring>

namespace volcl {
namespace {

/// What the renderers that do not draw gradient TFs are, for checkGradientTf's message.
constexpr std::string_view kNoGradientTf = "the tetrahedral-mesh renderers or the viewer's preview";

bool sameCamera(const Camera& a, const Camera& b) {
    return a.projection == b.projection && a.eye == b.eye && a.target == b.target && a.up == b.up &&
           a.height == b.height && a.fovYDeg == b.fovYDeg && a.mirrored == b.mirrored;
}

} // namespace

std::string tableKey(std::string_view source, const TableSpec& spec, std::string_view variant) {
    // Lengths with 17 digits: two steps that differ only in the last digits must not share a table.
    return std::string(source) + "|" + std::to_string(int(spec.axis)) + "|" + std::to_string(spec.size) +
           "|" + std::to_string(spec.lengths) + "|" + formatNumber(spec.step, 17) + "|" +
           formatNumber(spec.maxLength, 17) + "|" + std::string(variant);
}

RendererBase::RendererBase(ComputeContext& cc, const TransferFunction& tf, const Scene& scene)
    : cc_(cc), tf_(tf), scene_(scene) {
    scene_.validate();
    tf_.validate();
    out_ = cc_.allocate<cl_float4>(1);
    depth_ = cc_.allocate<float>(1);
    table_ = cc_.allocate<cl_float4>(1, CL_MEM_READ_ONLY);
}

void RendererBase::start(const WorldBox& box, const ValueRange& range) {
    box_ = box;
    range_ = range;
    checkGradientTf(scene_, tf_, drawsGradientTf(), kNoGradientTf);
    checkLabels(scene_, tf_, drawsLabels());
    admitScene(scene_);
    replan(true);
}

void RendererBase::setScene(const Scene& scene) {
    scene.validate();
    checkGradientTf(scene, tf_, drawsGradientTf(), kNoGradientTf);
    checkLabels(scene, tf_, drawsLabels());
    admitScene(scene);
    scene_ = scene;
    replan(false);
}

void RendererBase::setTransferFunction(const TransferFunction& tf) {
    tf.validate();
    checkGradientTf(scene_, tf, drawsGradientTf(), kNoGradientTf);
    checkLabels(scene_, tf, drawsLabels());
    tf_ = tf;
    replan(true);
}

void RendererBase::setView(const Camera& camera, int width, int height, double step) {
    Scene next = withView(scene_, camera, width, height, step);
    if (step != scene_.step && stepNeedsRebuild()) {
        setScene(next);
        return;
    }
    next.validate();
    const bool sameView = sameCamera(camera, camera_) && width == scene_.width && height == scene_.height;
    scene_ = std::move(next);
    camera_ = camera;
    viewChanged(sameView);
}

void RendererBase::replan(bool tfChanged) {
    camera_ = scene_.camera ? *scene_.camera : defaultCamera(bounds());
    const double previousColorScale = plan_.colorScale;
    plan_ = planEffects(scene_);
    planGradientTf(tf_, plan_);
    tableMs_ = 0.0;
    TransferFunction shaded = tf_;
    if (plan_.colorScale != 1.0) {
        for (auto& c : shaded.color)
            for (double& v : c.rgb)
                v *= plan_.colorScale;
        for (auto& w : shaded.widgets)
            for (double& v : w.rgb)
                v *= plan_.colorScale;
    }
    const bool knotsChanged = tfChanged || previousColorScale != plan_.colorScale || hostKnots_.empty();
    if (knotsChanged) {
        hostKnots_ = shaded.packKnots();
        // A gradient TF's records follow the value axis's knots in the same buffer (VolclTfParams).
        std::vector<VolclTfKnot> device = hostKnots_;
        const auto gradient = shaded.packGradientRecords();
        device.insert(device.end(), gradient.begin(), gradient.end());
        knots_ = cc_.upload(device, CL_MEM_READ_ONLY);
    }
    rebuild({shaded, tfChanged, knotsChanged});
}

std::optional<TableSpec> RendererBase::marchTableSpec() const {
    const Preintegration pre = scene_.mode == RenderMode::Dvr ? scene_.preintegration : Preintegration::None;
    if (pre == Preintegration::None) return std::nullopt;
    TableSpec spec;
    spec.size = scene_.tableSize;
    if (pre == Preintegration::Table2d) {
        spec.axis = LengthAxis::Fixed;
        spec.step = scene_.step;
    } else {
        spec.axis = LengthAxis::Linear;
        spec.lengths = scene_.tableLengths;
        spec.maxLength = scene_.step;
    }
    return spec;
}

void RendererBase::selectPreintegrationTable(const TransferFunction& shaded, const TableSpec& spec) {
    selectTable(tableKey(shaded.toJson(), spec), [&] {
        const PreintegrationTable t = generatePreintegrationTable(shaded, spec, {}, &cc_);
        std::vector<cl_float4> rgba(t.rgba.size() / 4);
        std::memcpy(rgba.data(), t.rgba.data(), rgba.size() * sizeof(cl_float4));
        return DeviceTable{cc_.upload(rgba, CL_MEM_READ_ONLY), int(t.sliceCount())};
    });
}

bool RendererBase::ensureFrameBuffers() {
    const std::size_t pixels = std::size_t(scene_.width) * std::size_t(scene_.height);
    if (out_.size() == pixels) return false;
    out_ = cc_.allocate<cl_float4>(pixels, CL_MEM_WRITE_ONLY);
    depth_ = cc_.allocate<float>(pixels, CL_MEM_WRITE_ONLY);
    return true;
}

ImageBuffer RendererBase::downloadFrame(bool withDepth) {
    const std::size_t pixels = std::size_t(scene_.width) * std::size_t(scene_.height);
    const auto rgba = cc_.download(out_);
    std::vector<std::string> channels{"R", "G", "B", "A"};
    if (withDepth) channels.push_back("Z");
    ImageBuffer img(scene_.width, scene_.height, channels);
    std::vector<float> depth;
    if (withDepth) depth = cc_.download(depth_);
    const std::size_t nc = std::size_t(img.channelCount());
    for (std::size_t i = 0; i < pixels; ++i) {
        for (std::size_t c = 0; c < 4; ++c)
            img.pixels[i * nc + c] = rgba[i].s[c];
        if (withDepth) img.pixels[i * nc + 4] = depth[i];
    }
    return img;
}

void RendererBase::addFrameAttributes(ImageBuffer& img, std::string_view method) const {
    img.attributes.push_back({"volcl:mode", std::string(renderModeName(scene_.mode))});
    if (!method.empty()) img.attributes.push_back({"volcl:method", std::string(method)});
    img.attributes.push_back({"volcl:step", static_cast<float>(scene_.step)});
    img.attributes.push_back(
        {"volcl:preintegration", std::string(preintegrationName(scene_.preintegration))});
    img.attributes.push_back({"volcl:effects", plan_.defines.toOptions()});
}

} // namespace volcl
