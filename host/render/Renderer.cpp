// The OpenCL ray marcher: effect planning, macrocell emptiness, tables, kernel parameters and launches.
#include "host/render/Renderer.hpp"

#include "cl/volcl_shared.h"
#include "host/Error.hpp"
#include "host/Volume.hpp"
#include "host/render/RenderDetail.hpp"
#include "host/render/VecMath.hpp"
#include "host/runtime/Timing.hpp"
#include "preintegration/PreintegrationTable.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

namespace volcl {
namespace {

constexpr unsigned kMacrocellEdge = 8; // voxels per macrocell edge: 8^3 cells keep the grid small and tight

std::string fmt(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

} // namespace

std::string EffectPlan::explain() const {
    std::ostringstream os;
    os << "compiled: " << defines.toOptions() << '\n';
    for (const auto& c : compiled)
        os << "  + " << c << '\n';
    for (const auto& d : dropped)
        os << "  - dropped " << d << '\n';
    return os.str();
}

namespace {
/// planEffects with the volume's value range already known: the Renderer scans the volume once, not on
/// every scene change (a 7M-voxel scan per adaptive-quality step change cost more than the coarse frame).
EffectPlan planEffectsInRange(const Scene& scene, const Volume& volume, const render_detail::ValueRange& range);
} // namespace

EffectPlan planEffects(const Scene& scene, const Volume& volume, const TransferFunction& tf) {
    (void)tf;
    return planEffectsInRange(scene, volume, render_detail::valueRange(volume));
}

namespace {
EffectPlan planEffectsInRange(const Scene& scene, const Volume& volume, const render_detail::ValueRange& range) {
    EffectPlan p;
    const SceneEffects& fx = scene.effects;
    const RenderMode mode = scene.mode;
    const bool marching = mode == RenderMode::Dvr || mode == RenderMode::Iso;
    const std::string modeName(renderModeName(mode));
    p.defines.set("MODE", static_cast<long long>(mode == RenderMode::Dvr   ? 0
                                                 : mode == RenderMode::Mip ? 1
                                                 : mode == RenderMode::Iso ? 2
                                                                           : 3));
    p.compiled.push_back("mode " + modeName);
    // Voxels keep their stored type on the device; the kernel converts on load (exact for all four types).
    p.voxelType = volume.type() == ScalarType::UInt8    ? 1
                  : volume.type() == ScalarType::UInt16 ? 2
                  : volume.type() == ScalarType::Int16  ? 3
                                                        : 0;
    p.defines.set("VOXEL_TYPE", static_cast<long long>(p.voxelType));

    // Iso-surfaces: crossed only when min < value <= max (the kernel's sign test), visible only if opaque at
    // all.
    if (!fx.isosurfaces.empty()) {
        if (!marching) {
            p.dropped.push_back("isosurfaces: mode " + modeName + " draws no surfaces");
        } else {
            for (const auto& iso : fx.isosurfaces) {
                const std::string name = "isosurface " + fmt(iso.value);
                if (iso.rgba[3] <= 0.0)
                    p.dropped.push_back(name + ": opacity 0");
                else if (!(iso.value > range.min && iso.value <= range.max))
                    p.dropped.push_back(name + ": outside the data range (" + fmt(range.min) + ", " +
                                        fmt(range.max) + "], never crossed");
                else
                    p.isosurfaces.push_back(iso);
            }
        }
    }
    if (!p.isosurfaces.empty()) {
        p.defines.set("ISO_COUNT", static_cast<long long>(p.isosurfaces.size()));
        p.compiled.push_back("isosurfaces: " + std::to_string(p.isosurfaces.size()) +
                             " (first hit refined by bisection, composited in ray order)");
    }

    std::size_t litLights = 0;
    for (const auto& l : scene.lights)
        if (l.intensity > 0.0 && (l.color[0] > 0.0 || l.color[1] > 0.0 || l.color[2] > 0.0)) ++litLights;
    const bool canLight = marching && litLights > 0;
    const std::string noLight =
        marching ? "no light with non-zero intensity" : "mode " + modeName + " is unlit";

    if (fx.shading) {
        if (!canLight)
            p.dropped.push_back("shading: " + noLight + " (rendered unshaded)");
        else if (fx.diffuse == 0.0 && fx.specular == 0.0) {
            p.colorScale = fx.ambient;
            p.dropped.push_back("shading: diffuse and specular are 0, so no gradients; ambient " +
                                fmt(fx.ambient) + " folded into the colours");
        } else {
            p.shading = true;
            p.defines.set("SHADING");
            p.compiled.push_back("shading: Blinn-Phong, " + std::to_string(litLights) +
                                 " light(s), ambient " + fmt(fx.ambient) + ", diffuse " + fmt(fx.diffuse) +
                                 ", specular " + fmt(fx.specular) + ", shininess " + fmt(fx.shininess));
        }
    }
    if (fx.gradient == GradientKind::Sobel) {
        if (p.shading) {
            p.sobel = true;
            p.defines.set("GRADIENT_SOBEL");
            p.compiled.push_back("gradient: Sobel");
        } else {
            p.dropped.push_back("gradient sobel: nothing uses gradients");
        }
    }
    if (fx.scattering) {
        if (fx.albedo <= 0.0)
            p.dropped.push_back("scattering: albedo 0");
        else if (!canLight)
            p.dropped.push_back("scattering: " + noLight);
        else {
            p.scattering = true;
            p.defines.set("SCATTERING");
            p.compiled.push_back("scattering: single, Henyey-Greenstein g " + fmt(fx.phaseG) + ", albedo " +
                                 fmt(fx.albedo));
        }
    }
    if (fx.shadows) {
        if (!p.shading && !p.scattering)
            p.dropped.push_back("shadows: nothing is lit");
        else {
            p.shadows = true;
            p.defines.set("SHADOWS");
            p.compiled.push_back("shadows: secondary marching toward each light");
        }
    }
    if (!fx.clipPlanes.empty()) {
        const auto box = render_detail::worldBox(volume);
        for (std::size_t i = 0; i < fx.clipPlanes.size(); ++i) {
            const ClipPlane& pl = fx.clipPlanes[i];
            bool allKept = true;
            for (int c = 0; c < 8; ++c) {
                const Vec3 corner{c & 1 ? box[1][0] : box[0][0], c & 2 ? box[1][1] : box[0][1],
                                  c & 4 ? box[1][2] : box[0][2]};
                if (dot(pl.normal, corner) + pl.offset < 0.0) allKept = false;
            }
            if (allKept)
                p.dropped.push_back("clip plane " + std::to_string(i) + ": keeps the whole volume");
            else
                p.clipPlanes.push_back(pl);
        }
        if (!p.clipPlanes.empty()) {
            p.clipping = true;
            p.defines.set("CLIPPING");
            p.compiled.push_back("clipping: " + std::to_string(p.clipPlanes.size()) +
                                 " plane(s) cut the ray interval");
        }
    }
    if (scene.preintegration != Preintegration::None) {
        if (mode != RenderMode::Dvr)
            p.dropped.push_back("pre-integration: mode " + modeName + " integrates no segments");
        else {
            p.defines.set("PREINT", scene.preintegration == Preintegration::Table2d ? 2LL : 3LL);
            p.compiled.push_back(scene.preintegration == Preintegration::Table2d
                                     ? "pre-integration: 2D table at the render step"
                                     : "pre-integration: 3D table over segment lengths");
        }
    }
    if (scene.skipping) {
        if (!marching)
            p.dropped.push_back("empty-space skipping: mode " + modeName + " visits every sample");
        else {
            p.skipping = true;
            p.defines.set("SKIPPING");
            p.compiled.push_back("empty-space skipping: " + std::to_string(kMacrocellEdge) +
                                 "^3-voxel macrocells");
        }
    }
    if (scene.earlyTermination < 1.0) {
        if (!marching)
            p.dropped.push_back("early termination: mode " + modeName + " has no opacity to saturate");
        else {
            p.earlyTermination = true;
            p.defines.set("EARLY_TERMINATION");
            p.compiled.push_back("early termination at opacity " + fmt(scene.earlyTermination));
        }
    }
    return p;
}
} // namespace

struct Renderer::Impl {
    render_detail::ValueRange range; ///< of the volume, scanned once at construction
    DeviceBuffer<cl_uchar> volume; ///< voxels in their stored type, plus one spare voxel (raymarch_core.h)
    DeviceBuffer<cl_uchar> corners; ///< uint8 volumes: 8 corner values per cell for the packet kernels
    bool useCorners = false;        ///< packet kernels read `corners` (-DCORNER_VOXELS)
    DeviceBuffer<VolclTfKnot> knots;
    DeviceBuffer<cl_float4> table;
    DeviceBuffer<cl_uchar> empty;
    DeviceBuffer<cl_float4> out;
    DeviceBuffer<float> depth;
    std::size_t knotCount = 0;
    render_detail::MacrocellGrid macro;
    std::vector<unsigned char> emptyHost;
    cl::Kernel kernel;
    bool packet = false; ///< kernel is raymarch_packet: one work-item per 4x2 block of pixels
    std::string tableKey;
    int tableLengths = 1;
    /// Recently used tables, most recent last: an interactive viewer alternates between a few steps, and a
    /// 2D table per step costs 10-100 ms to rebuild (far more than a coarse frame).
    struct CachedTable {
        std::string key;
        DeviceBuffer<cl_float4> table;
        int lengths = 1;
    };
    std::vector<CachedTable> tableCache;
    static constexpr std::size_t kTableCacheSize = 8;
    VolclRenderParams params{};
};

Renderer::Renderer(ComputeContext& cc, const Volume& volume, const TransferFunction& tf, const Scene& scene)
    : cc_(cc), volume_(volume), tf_(tf), scene_(scene), impl_(std::make_unique<Impl>()) {
    scene_.validate();
    tf_.validate();
    if (volume.empty()) throw DataError("volume is empty");
    if (volume.voxelCount() >= (std::size_t(1) << 32))
        throw DataError("volume has " + std::to_string(volume.voxelCount()) +
                        " voxels; the ray marcher indexes at most 2^32 - 1");
    if (volume.type() == ScalarType::Float32) {
        std::size_t bad = 0;
        for (float v : volume.values<float>())
            bad += std::isfinite(v) ? 0 : 1;
        if (bad)
            throw DataError("volume has " + std::to_string(bad) +
                            " NaN/Inf voxels; the ray marcher needs finite data (replace them first)");
    }
    std::vector<cl_uchar> bytes(volume.byteSize() + scalarSize(volume.type()), 0);
    std::memcpy(bytes.data(), volume.bytes().data(), volume.byteSize());
    impl_->volume = cc_.upload(bytes, CL_MEM_READ_ONLY);
    impl_->macro = render_detail::buildMacrocells(volume, kMacrocellEdge);
    impl_->range = render_detail::valueRange(volume);
    impl_->useCorners =
        volume.type() == ScalarType::UInt8 && volume.voxelCount() <= render_detail::kMaxCornerVoxels;
    impl_->out = cc_.allocate<cl_float4>(1);
    impl_->depth = cc_.allocate<float>(1);
    rebuild(true);
}

Renderer::~Renderer() = default;

std::size_t Renderer::macrocellCount() const noexcept {
    return impl_->macro.min.size();
}

void Renderer::setScene(const Scene& scene) {
    scene.validate();
    scene_ = scene;
    rebuild(false);
}

void Renderer::setView(const Camera& camera, int width, int height, double step) {
    Scene s = scene_;
    s.camera = camera;
    s.width = width;
    s.height = height;
    s.step = step;
    if (step != scene_.step) {
        setScene(s);
        return;
    }
    s.validate();
    scene_ = s;
    camera_ = camera;
    render_detail::setCameraParams(impl_->params, scene_, camera_);
}

void Renderer::setTransferFunction(const TransferFunction& tf) {
    tf.validate();
    tf_ = tf;
    rebuild(true);
}

void Renderer::rebuild(bool tfChanged) {
    camera_ = scene_.camera ? *scene_.camera : defaultCamera(volume_);
    const EffectPlan previous = plan_;
    plan_ = planEffectsInRange(scene_, volume_, impl_->range);
    Impl& m = *impl_;

    const auto box = render_detail::worldBox(volume_);
    scene_.validateSteps(norm(sub(box[1], box[0])));

    TransferFunction shaded = tf_;
    if (plan_.colorScale != 1.0)
        for (auto& c : shaded.color)
            for (double& v : c.rgb)
                v *= plan_.colorScale;
    if (tfChanged || previous.colorScale != plan_.colorScale) {
        const auto knots = shaded.packKnots();
        m.knots = cc_.upload(knots, CL_MEM_READ_ONLY);
        m.knotCount = knots.size();
    }

    // Pre-integration table: rebuilt when the TF, the step, the size or the kind changes.
    const Preintegration pre = scene_.mode == RenderMode::Dvr ? scene_.preintegration : Preintegration::None;
    tableMs_ = 0.0;
    if (pre != Preintegration::None) {
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
        const std::string key = shaded.toJson() + "|" + std::to_string(int(pre)) + "|" +
                                std::to_string(spec.size) + "|" + fmt(scene_.step) + "|" +
                                std::to_string(spec.lengths);
        if (key != m.tableKey) {
            auto hit = std::find_if(m.tableCache.begin(), m.tableCache.end(),
                                    [&](const Impl::CachedTable& c) { return c.key == key; });
            Impl::CachedTable entry;
            if (hit != m.tableCache.end()) {
                entry = std::move(*hit);
                m.tableCache.erase(hit);
            } else {
                Stopwatch sw;
                const PreintegrationTable t = generatePreintegrationTable(shaded, spec, {}, &cc_);
                tableMs_ = sw.milliseconds();
                std::vector<cl_float4> rgba(t.rgba.size() / 4);
                std::memcpy(rgba.data(), t.rgba.data(), rgba.size() * sizeof(cl_float4));
                entry = {key, cc_.upload(rgba, CL_MEM_READ_ONLY), int(t.sliceCount())};
            }
            m.table = entry.table;
            m.tableKey = key;
            m.tableLengths = entry.lengths;
            m.tableCache.push_back(std::move(entry));
            if (m.tableCache.size() > Impl::kTableCacheSize) m.tableCache.erase(m.tableCache.begin());
        }
    } else if (m.table.size() == 0) {
        m.table = cc_.allocate<cl_float4>(1, CL_MEM_READ_ONLY);
    }

    // Macrocell emptiness from the TF (and the iso-values), for the sampling the kernel will use.
    std::vector<double> isoValues;
    for (const auto& iso : plan_.isosurfaces)
        isoValues.push_back(iso.value);
    const int tableNodes = pre != Preintegration::None ? scene_.tableSize : 0;
    m.emptyHost = render_detail::emptyMacrocells(m.macro, shaded, isoValues, scene_.mode == RenderMode::Iso,
                                                 tableNodes);
    std::size_t emptyCount = 0;
    for (unsigned char e : m.emptyHost)
        emptyCount += e;
    emptyFraction_ = m.emptyHost.empty() ? 0.0 : double(emptyCount) / double(m.emptyHost.size());
    m.empty = cc_.upload(m.emptyHost, CL_MEM_READ_ONLY);

    // Unlit DVR without iso-surfaces (the common, time-critical case) runs as explicit 8-ray packets.
    m.packet = scene_.mode == RenderMode::Dvr && !plan_.shading && !plan_.scattering && plan_.isosurfaces.empty();
    m.kernel = cc_.kernel("raymarch.cl", m.packet ? "raymarch_packet" : "raymarch", m.packet ? packetDefines(plan_.defines) : plan_.defines);
    m.params =
        render_detail::makeParams(scene_, camera_, volume_, tf_, plan_, m.macro, m.knotCount, m.tableLengths);
}

KernelDefines Renderer::packetDefines(KernelDefines d) {
    Impl& m = *impl_;
    if (m.useCorners) {
        // A memory layout, not an effect: kept out of plan_.defines (what --explain and the EXR report).
        d.set("CORNER_VOXELS");
        if (m.corners.size() == 0) m.corners = cc_.upload(render_detail::cellCorners(volume_), CL_MEM_READ_ONLY);
    }
    return d;
}

ImageBuffer Renderer::launch(cl::Kernel& kernel, bool withDepth, bool packet) {
    Impl& m = *impl_;
    const std::size_t pixels = std::size_t(scene_.width) * std::size_t(scene_.height);
    if (m.out.size() != pixels) {
        m.out = cc_.allocate<cl_float4>(pixels, CL_MEM_WRITE_ONLY);
        m.depth = cc_.allocate<float>(pixels, CL_MEM_WRITE_ONLY);
    }
    setArgs(kernel, packet && m.useCorners ? m.corners : m.volume, m.knots, m.table, m.empty, m.params, m.out,
            m.depth);
    // Tiles of nearby rays share cache lines in y as well as x: 8x8 rays, or 4x4 packets of 4x2 rays.
    const std::size_t w = std::size_t(scene_.width), h = std::size_t(scene_.height);
    cl::Event ev = packet ? cc_.launch2d(kernel, (w + 3) / 4, (h + 1) / 2, 4, 4) : cc_.launch2d(kernel, w, h, 8, 8);
    lastMs_ = eventMilliseconds(ev);
    const auto rgba = cc_.download(m.out);
    std::vector<std::string> channels{"R", "G", "B", "A"};
    if (withDepth) channels.push_back("Z");
    ImageBuffer img(scene_.width, scene_.height, channels);
    std::vector<float> depth;
    if (withDepth) depth = cc_.download(m.depth);
    const int nc = img.channelCount();
    for (std::size_t i = 0; i < pixels; ++i) {
        for (int c = 0; c < 4; ++c)
            img.pixels[i * nc + c] = rgba[i].s[c];
        if (withDepth) img.pixels[i * nc + 4] = depth[i];
    }
    img.attributes.push_back({"volcl:mode", std::string(renderModeName(scene_.mode))});
    img.attributes.push_back({"volcl:step", static_cast<float>(scene_.step)});
    img.attributes.push_back(
        {"volcl:preintegration", std::string(preintegrationName(scene_.preintegration))});
    img.attributes.push_back({"volcl:effects", plan_.defines.toOptions()});
    return img;
}

const cl::Buffer& Renderer::outputBuffer() const noexcept {
    return impl_->out.get();
}

ImageBuffer Renderer::render() {
    return launch(impl_->kernel, !plan_.isosurfaces.empty(), impl_->packet);
}

ImageBuffer Renderer::renderPlainBaseline() {
    if (scene_.mode != RenderMode::Dvr || scene_.preintegration != Preintegration::None)
        throw UsageError("the plain baseline kernel renders point-sampled dvr only");
    KernelDefines d;
    d.set("VOXEL_TYPE", static_cast<long long>(plan_.voxelType));
    cl::Kernel k = cc_.kernel("raymarch_plain.cl", "raymarch_plain", packetDefines(d));
    return launch(k, false, true);
}

double imageRmse(const ImageBuffer& a, const ImageBuffer& b) {
    if (a.width != b.width || a.height != b.height) throw UsageError("imageRmse: images differ in size");
    double sum = 0.0;
    std::size_t n = 0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = 0; c < 4; ++c) {
                const double d = double(a.at(x, y, c)) - double(b.at(x, y, c));
                sum += d * d;
                ++n;
            }
    return std::sqrt(sum / double(n));
}

} // namespace volcl
