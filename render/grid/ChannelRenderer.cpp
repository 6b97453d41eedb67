// Multi-channel grid rendering: scene checks, the OpenCL renderer and the double-precision reference.
#include "render/grid/ChannelRenderer.hpp"

#include "cl/render/channels_shared.h"
#include "core/Error.hpp"
#include "render/FrameParams.hpp"
#include "render/RenderInput.hpp"
#include "render/grid/GridDetail.hpp"
#include "render/grid/GridRenderer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace volcl {

namespace {

// The kernel's code for a channel's stored type (CH_TYPE<c>, as VOXEL_TYPE in cl/common/grid_sample.h).
int clTypeCode(ScalarType t) {
    switch (t) {
    case ScalarType::UInt8:
        return 1;
    case ScalarType::UInt16:
        return 2;
    case ScalarType::Int16:
        return 3;
    case ScalarType::Float32:
        return 0;
    case ScalarType::Float64: // narrowed by kernelVoxels before any kernel sees it
        break;
    }
    throw Error("internal: float64 channel reached the kernel");
}

// DirectColor: the factor that takes a stored value to [0, 1] (floats are taken as stored).
double colorScaleOf(ScalarType t) {
    switch (t) {
    case ScalarType::UInt8:
        return 1.0 / 255.0;
    case ScalarType::UInt16:
        return 1.0 / 65535.0;
    case ScalarType::Int16:
        return 1.0 / 32767.0;
    case ScalarType::Float32:
    case ScalarType::Float64:
        return 1.0;
    }
    return 1.0;
}

// The NaN colour as (r, g, b, tau): the scene's straight colour and A turned into an extinction per world
// unit (A = 1: the imported-opacity cap), as the single-channel renderers take it.
std::array<double, 4> nanRgbt(const Scene& scene) {
    const auto& c = scene.nanColor;
    const double a = std::clamp(c[3], 0.0, 1.0);
    const double tau = a >= 1.0 ? 1000.0 : -std::log1p(-a);
    return {c[0], c[1], c[2], tau};
}

Camera cameraOf(const ChannelVolume& volume, const Scene& scene) {
    return scene.camera ? *scene.camera : defaultCamera(gridBounds(volume.channels.front()));
}

} // namespace

ChannelBlend parseChannelBlend(std::string_view name) {
    if (name == "additive") return ChannelBlend::Additive;
    if (name == "max" || name == "maximum") return ChannelBlend::Maximum;
    if (name == "direct") return ChannelBlend::DirectColor;
    throw UsageError("channel blend '" + std::string(name) + "' is not additive, max or direct");
}

std::string_view channelBlendName(ChannelBlend blend) noexcept {
    switch (blend) {
    case ChannelBlend::Additive:
        return "additive";
    case ChannelBlend::Maximum:
        return "max";
    case ChannelBlend::DirectColor:
        return "direct";
    }
    return "additive";
}

ChannelVolume readSceneChannels(const Scene& scene, const ReadOptions& options) {
    if (scene.channels.empty()) return readVolumeChannels(scene.volume, options);
    std::optional<ChannelVolume> own; // the scene's volume, read once for every entry that names it
    ChannelVolume out;
    for (std::size_t i = 0; i < scene.channels.size(); ++i) {
        const SceneChannel& c = scene.channels[i];
        if (c.volume.empty() || c.volume == scene.volume) {
            if (!own) own = readVolumeChannels(scene.volume, options);
            const std::size_t k = c.channel.value_or(i);
            if (k >= own->count())
                throw UsageError(scene.volume.string() + ": channel " + std::to_string(k) +
                                 " of scene entry " + std::to_string(i) + " is past its " +
                                 std::to_string(own->count()) + " channels");
            out.channels.push_back(own->channels[k]);
        } else {
            ReadOptions o = options;
            o.channel = c.channel.value_or(0);
            out.channels.push_back(readVolume(c.volume, o));
        }
    }
    for (std::size_t i = 1; i < out.count(); ++i)
        if (out.channels[i].dims() != out.channels[0].dims())
            throw DataError("channel " + std::to_string(i) + " has a different size than channel 0");
    // Files of one grid may state it apart in the last float digit: the first channel's geometry holds.
    for (Volume& v : out.channels) {
        v = kernelVoxels(std::move(v));
        v.spacing = out.channels[0].spacing;
        v.origin = out.channels[0].origin;
        v.direction = out.channels[0].direction;
    }
    out.validate();
    return out;
}

ChannelStyle sceneChannelStyle(const Scene& scene, const ChannelVolume& volume, double opacityUnitDistance) {
    ChannelStyle style;
    if (scene.directColor) {
        style.blend = ChannelBlend::DirectColor;
        style.layers.push_back(
            {TransferFunction::forRender(scene.tf.empty() ? std::nullopt : std::optional(scene.tf),
                                         {0.0, 1.0}, opacityUnitDistance),
             true});
        return style;
    }
    style.blend = parseChannelBlend(scene.channelBlend);
    for (std::size_t c = 0; c < volume.count(); ++c) {
        const VolumeStats st = volume.channels[c].stats(1);
        const SceneChannel entry = c < scene.channels.size() ? scene.channels[c] : SceneChannel{};
        style.layers.push_back(
            {TransferFunction::forRender(entry.tf.empty() ? std::nullopt : std::optional(entry.tf),
                                         {st.min, st.max}, opacityUnitDistance),
             entry.visible});
    }
    return style;
}

void checkChannelScene(const ChannelVolume& volume, const ChannelStyle& style, const Scene& scene) {
    volume.validate();
    const std::size_t n = volume.count();
    if (n > kMaxRenderChannels)
        throw UsageError(std::to_string(n) + " channels: the multi-channel renderer draws at most " +
                         std::to_string(kMaxRenderChannels) + " (choose one with --channel K)");
    if (style.blend == ChannelBlend::DirectColor) {
        if (n != 3 && n != 4)
            throw UsageError("\"color\": \"direct\" needs 3 (RGB) or 4 (RGBA) channels, the volume has " +
                             std::to_string(n));
        if (style.layers.empty()) throw UsageError("\"color\": \"direct\" needs a TF for the opacity");
    } else if (style.layers.size() != n) {
        throw UsageError(std::to_string(style.layers.size()) + " channel TFs for " + std::to_string(n) +
                         " channels: give one per channel");
    }
    for (const ChannelLayer& l : style.layers)
        if (l.tf.usesGradient())
            throw UsageError("channels: gradient transfer functions are not supported per channel");
    const bool mip = style.blend == ChannelBlend::Maximum;
    if (scene.mode != (mip ? RenderMode::Mip : RenderMode::Dvr))
        throw UsageError(std::string("channels: blend '") + std::string(channelBlendName(style.blend)) +
                         "' renders in mode " + (mip ? "mip" : "dvr") + " only");
    const SceneEffects& fx = scene.effects;
    auto refuse = [](const char* what) {
        throw UsageError(std::string("channels: ") + what + " is not supported with several channels");
    };
    if (fx.shading) refuse("shading");
    if (fx.shadows) refuse("shadows");
    if (fx.scattering) refuse("scattering");
    if (fx.fog.enabled) refuse("fog");
    if (!fx.isosurfaces.empty()) refuse("an iso-surface");
    if (scene.filter != ReconstructionFilter::Linear) refuse("a cubic filter");
    if (scene.smoothing > 0) refuse("smoothing");
    if (scene.preintegration != Preintegration::None) refuse("pre-integration");
}

ChannelRenderer::ChannelRenderer(ComputeContext& cc, const ChannelVolume& volume, ChannelStyle style,
                                 const Scene& scene)
    : cc_(cc), volume_(volume), style_(std::move(style)), scene_(scene) {
    checkChannelScene(volume_, style_, scene_);
    KernelDefines d;
    d.set("CHANNELS", static_cast<int>(volume_.count()));
    d.set("BLEND", static_cast<int>(style_.blend));
    for (std::size_t c = 0; c < kMaxRenderChannels; ++c) {
        const ScalarType t = c < volume_.count() ? volume_.channels[c].type() : ScalarType::UInt8;
        d.set("CH_TYPE" + std::to_string(c), clTypeCode(t));
    }
    kernel_ = cc_.kernel("render/raymarch_channels.cl", "raymarch_channels", d);
    // Each channel keeps its stored type on the device, with one spare voxel for the kernel's paired loads.
    for (std::size_t c = 0; c < kMaxRenderChannels; ++c) {
        if (c < volume_.count()) {
            const Volume& v = volume_.channels[c];
            std::vector<std::byte> bytes(v.bytes().begin(), v.bytes().end());
            bytes.resize(bytes.size() + scalarSize(v.type()), std::byte{0});
            voxels_.push_back(cc_.upload<std::byte>(bytes, CL_MEM_READ_ONLY).get());
        } else {
            voxels_.push_back(cc_.allocate<std::byte>(8, CL_MEM_READ_ONLY).get());
        }
    }
    std::vector<VolclTfKnot> knots;
    for (const ChannelLayer& l : style_.layers) {
        const std::vector<VolclTfKnot> k = l.tf.packKnots();
        knots.insert(knots.end(), k.begin(), k.end());
    }
    knots_ = cc_.upload(knots, CL_MEM_READ_ONLY);
}

ImageBuffer ChannelRenderer::render() {
    VolclChannelRenderParams p{};
    const Volume& grid = volume_.channels.front();
    p.camera = cameraParams(cameraOf(volume_, scene_), scene_.width, scene_.height);
    p.clip = clipParams(activeClipPlanes(scene_.effects));
    p.march = marchParams(scene_, ValueRange{0.0, 1.0});
    p.grid = grid_detail::gridParams(grid, grid_detail::MacrocellGrid{});
    std::uint32_t start = 0;
    for (std::size_t c = 0; c < style_.layers.size() && c < kMaxRenderChannels; ++c) {
        const auto count = static_cast<std::uint32_t>(style_.layers[c].tf.packKnots().size());
        p.channels.knotStart[c] = start;
        p.channels.knotCount[c] = count;
        p.channels.visible[c] = style_.layers[c].visible ? 1u : 0u;
        start += count;
    }
    for (std::size_t c = 0; c < volume_.count(); ++c)
        p.channels.colorScale[c] = static_cast<float>(colorScaleOf(volume_.channels[c].type()));
    const auto nan = nanRgbt(scene_);
    for (int i = 0; i < 4; ++i)
        p.channels.nanRgbt[i] = static_cast<float>(nan[std::size_t(i)]);
    const auto w = static_cast<std::size_t>(scene_.width), h = static_cast<std::size_t>(scene_.height);
    DeviceBuffer<cl_float4> out = cc_.allocate<cl_float4>(w * h, CL_MEM_WRITE_ONLY);
    setArgs(kernel_, voxels_[0], voxels_[1], voxels_[2], voxels_[3], knots_.get(), p, out.get());
    cl::Event e = cc_.launch2d(kernel_, w, h);
    e.wait();
    lastMs_ = eventMilliseconds(e);
    std::vector<cl_float4> px(w * h);
    cc_.read(out, std::span<cl_float4>(px));
    ImageBuffer img(scene_.width, scene_.height, {"R", "G", "B", "A"});
    for (std::size_t i = 0; i < px.size(); ++i)
        for (int c = 0; c < 4; ++c)
            img.pixels[4 * i + std::size_t(c)] = px[i].s[c];
    return img;
}

ImageBuffer referenceChannelRender(const ChannelVolume& volume, const ChannelStyle& style, const Scene& scene,
                                   const ReferenceOptions& options) {
    checkChannelScene(volume, style, scene);
    const Volume& grid = volume.channels.front();
    const std::size_t n = volume.count();
    std::vector<std::vector<float>> values;
    for (const Volume& v : volume.channels)
        values.push_back(v.toFloat());
    const std::array<std::size_t, 3> dims{grid.dims().x, grid.dims().y, grid.dims().z};
    const std::vector<ClipPlane> planes = activeClipPlanes(scene.effects);
    const auto nan = nanRgbt(scene);
    const double inf = std::numeric_limits<double>::infinity();
    // (r, g, b, tau) of channel c at value s, exactly.
    auto classify = [&](std::size_t c, double s) -> std::array<double, 4> {
        if (!std::isfinite(s)) return nan;
        const TransferFunction& tf = style.layers[c].tf;
        const auto rgb = tf.colorAt(s);
        return {rgb[0], rgb[1], rgb[2], tf.extinctionAt(s)};
    };
    auto trace = [&](const CameraRay& ray) -> ReferencePixel {
        // The box [origin, origin + (n - 1) spacing] in the grid's index-aligned frame.
        double t0 = 0.0, t1 = inf;
        for (std::size_t a = 0; a < 3; ++a) {
            const double lo = grid.origin[a], hi = lo + double(dims[a] - 1) * grid.spacing[a];
            const double o = ray.origin[a], d = ray.direction[a];
            if (d == 0.0) {
                if (o < lo || o > hi) return emptyReferencePixel();
                continue;
            }
            const double ta = (lo - o) / d, tb = (hi - o) / d;
            t0 = std::max(t0, std::min(ta, tb));
            t1 = std::min(t1, std::max(ta, tb));
        }
        if (!clipToPlanes(planes, ray, t0, t1) || !(t1 > t0)) return emptyReferencePixel();
        const double step = options.step;
        const int nseg = std::max(static_cast<int>(std::ceil((t1 - t0) / step)), 1);
        std::array<double, 4> best{-inf, -inf, -inf, -inf};
        double cr = 0, cg = 0, cb = 0, T = 1;
        for (int k = 0; k < nseg; ++k) {
            const double a0 = t0 + k * step, a1 = k == nseg - 1 ? t1 : std::min(a0 + step, t1);
            const double len = a1 - a0, t = a0 + 0.5 * len;
            Vec3 p;
            for (std::size_t a = 0; a < 3; ++a)
                p[a] = (ray.origin[a] + t * ray.direction[a] - grid.origin[a]) / grid.spacing[a];
            std::array<double, 4> s{0, 0, 0, 0};
            for (std::size_t c = 0; c < n; ++c)
                s[c] = grid_detail::trilinear(values[c], dims, p);
            if (style.blend == ChannelBlend::Maximum) {
                for (std::size_t c = 0; c < n; ++c)
                    if (std::isfinite(s[c])) best[c] = std::max(best[c], s[c]);
                continue;
            }
            double sigma = 0, er = 0, eg = 0, eb = 0;
            if (style.blend == ChannelBlend::DirectColor) {
                std::array<double, 4> e;
                if (!(std::isfinite(s[0]) && std::isfinite(s[1]) && std::isfinite(s[2]) &&
                      std::isfinite(s[3]))) {
                    e = nan;
                } else {
                    double rgb[3];
                    for (std::size_t c = 0; c < 3; ++c)
                        rgb[c] = s[c] * colorScaleOf(volume.channels[c].type());
                    const double opacity = n > 3 ? s[3] * colorScaleOf(volume.channels[3].type())
                                                 : 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
                    e = {rgb[0], rgb[1], rgb[2], style.layers[0].tf.extinctionAt(opacity)};
                }
                sigma = e[3];
                er = e[0] * sigma;
                eg = e[1] * sigma;
                eb = e[2] * sigma;
            } else {
                for (std::size_t c = 0; c < n; ++c) {
                    if (!style.layers[c].visible) continue;
                    const auto e = classify(c, s[c]);
                    sigma += e[3];
                    er += e[3] * e[0];
                    eg += e[3] * e[1];
                    eb += e[3] * e[2];
                }
            }
            if (sigma > 0) {
                const double a = -std::expm1(-sigma * len), f = T * a / sigma;
                cr += f * er;
                cg += f * eg;
                cb += f * eb;
                T *= 1.0 - a;
            }
        }
        if (style.blend == ChannelBlend::Maximum) {
            ReferencePixel px = emptyReferencePixel();
            double keep = 1.0;
            for (std::size_t c = 0; c < n; ++c) {
                if (!style.layers[c].visible || best[c] == -inf) continue;
                const auto e = classify(c, best[c]);
                const double a = -std::expm1(-e[3]);
                for (int i = 0; i < 3; ++i)
                    px[std::size_t(i)] += a * e[std::size_t(i)];
                keep *= 1.0 - a;
            }
            px[3] = 1.0 - keep;
            return px;
        }
        ReferencePixel px = emptyReferencePixel();
        px[0] = cr;
        px[1] = cg;
        px[2] = cb;
        px[3] = 1.0 - T;
        return px;
    };
    return traceReferenceImage(scene, cameraOf(volume, scene), false, options.threads, trace);
}

} // namespace volcl
