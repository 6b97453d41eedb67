// Decoding one frame's bricks into a region of the output.
#include "wavelet/FrameDecoder.hpp"

#include "core/Error.hpp"
#include "core/runtime/ParallelFor.hpp"
#include "wavelet/BrickVoxels.hpp"
#include "wavelet/entropy/EntropyCoder.hpp"
#include "wavelet/payload/BrickPayload.hpp"
#include "wavelet/payload/VoxelBrick.hpp"
#include "wavelet/quantise/Corrections.hpp"
#include "wavelet/transform/BrickTransform.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <optional>

namespace volcl::codec {

std::vector<Correction> entropyDecodeBrick(std::span<const std::byte> file, const VczHeader& h,
                                           std::size_t frame, std::size_t b, int level, std::int32_t* dst,
                                           std::size_t pitch, const std::string& name) {
    const int levels = h.transform == TransformKind::RawBits ? 0 : h.levels;
    const int stop = h.transform == TransformKind::RawBits ? 0 : level;
    const Dequantiser dq{h.steps, h.reconstructionBias};
    const std::string what = name + ": brick " + std::to_string(b);
    const auto payload = vczBrickPayload(file, h, frame, b, name);
    const Dims d = h.brickDims(b), storage{pitch, d.y, d.z};
    const auto layout = sectionLayout(d, levels);
    const ParsedPayload p = parsePayload(payload, layout.size(), what);
    const std::span<std::int32_t> c(dst, storage.count());
    // Sections finer than the level are not decoded; the inverse never reads them, but keep them defined.
    if (stop > 0) std::fill(c.begin(), c.end(), 0);
    decodeSections(std::span(p.sections).first(layout.size() - std::size_t(stop)), c, storage, layout,
                   h.entropy, what.c_str(), h.transform == TransformKind::FloatLifting ? &dq : nullptr,
                   p.setPartitioned);
    if (p.corrections.empty() || level != 0) return {};
    return decodeCorrections(p.corrections, h.type, d.count(), what);
}

namespace {

// Brick b at level k: its first sample index per axis, and the part of it inside [a, e) as [lo, hi) per
// axis (level-k sample indices; sample j sits at full-resolution voxel j * 2^k). Empty when lo >= hi on an
// axis.
struct LevelBox {
    Dims first, lo, hi;
};
LevelBox brickBoxAt(const VczHeader& h, std::size_t b, int level, Dims a, Dims e) {
    const Dims o = h.brickOrigin(b), d = h.brickDims(b);
    const std::size_t f = std::size_t(1) << level;
    auto up = [f](std::size_t v) { return (v + f - 1) / f; };
    const Dims first{up(o.x), up(o.y), up(o.z)}, last{up(o.x + d.x), up(o.y + d.y), up(o.z + d.z)};
    return {first,
            {std::max(first.x, a.x), std::max(first.y, a.y), std::max(first.z, a.z)},
            {std::min(last.x, e.x), std::min(last.y, e.y), std::min(last.z, e.z)}};
}

// Copies the samples of brick b that fall in [a, e) (see brickBoxAt) into `out`. `src` holds the brick with
// rows of `pitch` elements: for lifting bricks the inverse-transformed batch slot with the level-k
// approximation in its low corner, for raw bricks the dense decoded bit patterns (decimated here).
// Corrections apply at full resolution.
template <class V, class S>
void placeBrick(const VczHeader& h, std::size_t b, int level, Dims a, Dims e, std::span<V> out, Dims outDims,
                const S* src, std::size_t pitch, const std::vector<Correction>& corrections) {
    const Dims o = h.brickOrigin(b), d = h.brickDims(b);
    const bool raw = h.transform == TransformKind::RawBits;
    const std::size_t f = std::size_t(1) << level;
    const auto [first, lo, hi] = brickBoxAt(h, b, level, a, e);
    auto local = [&](std::size_t j, std::size_t origin, std::size_t firstJ) {
        return raw ? j * f - origin : j - firstJ;
    };
    const std::size_t x0 = lo.x, x1 = hi.x;
    for (std::size_t z = lo.z; z < hi.z; ++z)
        for (std::size_t y = lo.y; y < hi.y; ++y) {
            const S* row = src + (local(z, o.z, first.z) * d.y + local(y, o.y, first.y)) * pitch;
            V* dst = out.data() + ((z - a.z) * outDims.y + (y - a.y)) * outDims.x;
            if (!raw && x0 < x1) {
                // Lifting bricks: one contiguous run per row, converted in a loop the compiler vectorises.
                const S* in = row + (x0 - first.x);
                V* o1 = dst + (x0 - a.x);
                const std::size_t len = x1 - x0;
                if constexpr (std::is_same_v<S, std::int32_t>) {
                    for (std::size_t i = 0; i < len; ++i) {
                        if constexpr (std::is_same_v<V, float>)
                            o1[i] = static_cast<float>(in[i]);
                        else
                            o1[i] = static_cast<V>(std::clamp<std::int32_t>(
                                in[i], std::numeric_limits<V>::min(), std::numeric_limits<V>::max()));
                    }
                } else {
                    for (std::size_t i = 0; i < len; ++i)
                        o1[i] = toVoxel<V>(in[i]);
                }
                continue;
            }
            if constexpr (std::is_same_v<S, std::int32_t>)
                for (std::size_t x = x0; x < x1; ++x) { // raw bricks (decimated at level k)
                    const std::int32_t bits = row[local(x, o.x, first.x)];
                    V v;
                    if constexpr (std::is_same_v<V, float>)
                        std::memcpy(&v, &bits, 4);
                    else
                        v = static_cast<V>(bits);
                    dst[x - a.x] = v;
                }
        }
    if (level == 0) applyCorrections(h, b, a, e, out, outDims, corrections);
}

// The value of every voxel of a lossless integer brick whose index entry has min == max (e.g. the empty
// space around a scan), when it is one of V's values.
template <class V> std::optional<V> uniformValue(const VczHeader& h, const VczBrickEntry& entry) {
    if constexpr (std::is_integral_v<V>) {
        const double v = entry.min;
        if (h.transform == TransformKind::IntegerLifting && entry.max == v && v == std::floor(v) &&
            v >= double(std::numeric_limits<V>::min()) && v <= double(std::numeric_limits<V>::max()))
            return static_cast<V>(v);
    }
    return std::nullopt;
}

} // namespace

bool voxelCodedBrick(std::span<const std::byte> file, const VczHeader& h, std::size_t frame, std::size_t b) {
    if (!h.voxelBricks) return false;
    const VczBrickEntry& entry = h.bricks[frame][b];
    // readVczHeader checked that every payload lies inside the file.
    return entry.size > 0 && entry.offset < file.size() &&
           std::to_integer<std::uint8_t>(file[entry.offset]) == 0;
}

std::vector<std::size_t> varyingBricks(std::span<const std::byte> file, const VczHeader& h, std::size_t frame,
                                       const std::vector<std::size_t>& which) {
    std::vector<std::size_t> varying;
    auto split = [&]<class V>() {
        for (std::size_t b : which)
            if (!uniformValue<V>(h, h.bricks[frame][b]) && !voxelCodedBrick(file, h, frame, b))
                varying.push_back(b);
    };
    switch (h.type) {
    case ScalarType::UInt8:
        split.template operator()<std::uint8_t>();
        break;
    case ScalarType::UInt16:
        split.template operator()<std::uint16_t>();
        break;
    case ScalarType::Int16:
        split.template operator()<std::int16_t>();
        break;
    case ScalarType::Float32:
        split.template operator()<float>();
        break;
    case ScalarType::Float64: // bricks hold a float64 volume's float32 layer: the header says Float32
        throw Error("internal: float64 bricks");
    }
    return varying;
}

namespace {

// Decodes voxel-coded brick b and places its part of [a, e) at `level`: the voxels themselves at level 0;
// coarser, the low band of the file's forward transform of them (integer lifting: exactly what a wavelet
// brick of the same voxels gives; float lifting: its unquantised form), or every 2^level-th voxel of a raw
// file, as placeBrick decimates raw bricks.
template <class V>
void placeVoxelBrick(std::span<const std::byte> file, const VczHeader& h, std::size_t frame, std::size_t b,
                     int level, Dims a, Dims e, std::span<V> out, Dims outDims, const std::string& name) {
    const Dims d = h.brickDims(b);
    std::vector<std::int32_t> vox = decodeVoxelBrick(vczBrickPayload(file, h, frame, b, name), h.type, d,
                                                     name + ": brick " + std::to_string(b));
    const std::vector<Correction> none;
    if (h.transform != TransformKind::FloatLifting) {
        if (level > 0 && h.transform == TransformKind::IntegerLifting)
            reference::forward3d(std::span<std::int32_t>(vox), d, level, h.wavelet);
        placeBrick(h, b, level, a, e, out, outDims, vox.data(), d.x, none);
        return;
    }
    auto valueOf = [&](std::int32_t v) {
        return h.type == ScalarType::Float32 ? std::bit_cast<float>(v) : static_cast<float>(v);
    };
    std::vector<float> values(vox.size());
    if (level == 0) {
        std::transform(vox.begin(), vox.end(), values.begin(), valueOf);
    } else {
        std::vector<double> low(vox.size());
        std::transform(vox.begin(), vox.end(), low.begin(), valueOf);
        reference::forward3d(std::span<double>(low), d, level, h.wavelet);
        std::transform(low.begin(), low.end(), values.begin(),
                       [](double v) { return static_cast<float>(v); });
    }
    placeBrick(h, b, level, a, e, out, outDims, values.data(), d.x, none);
}

// Entropy decodes the listed bricks of one frame on host threads, inverts them on the device down to
// `level` and places each brick's part of [a, e) into `out` (zero on entry) straight from the mapped batch.
// Lossy bricks are dequantised while they are entropy decoded (the quantise stage's reconstruction).
template <class V>
void decodeBricksInto(ComputeContext& cc, std::span<const std::byte> file, const VczHeader& h,
                      std::size_t frame, const std::vector<std::size_t>& which, int level, unsigned threads,
                      const std::string& name, CodecProfile* prof, Dims a, Dims e, std::span<V> out,
                      Dims outDims, bool placeOnDevice, std::vector<std::vector<Correction>>* deferred,
                      DecodeAhead* ahead) {
    const std::size_t n = h.brickCount();
    std::vector<std::vector<std::int32_t>> ints(n);
    std::vector<std::vector<Correction>> corrections(n);
    // Entropy decodes brick b into rows of `pitch` elements (a batch slot, or a dense array); lossy bricks
    // come out dequantised (float bit patterns).
    auto entropyDecode = [&](std::size_t b, std::int32_t* dst, std::size_t pitch) {
        corrections[b] = entropyDecodeBrick(file, h, frame, b, level, dst, pitch, name);
    };
    const std::vector<Correction> none;
    auto place = [&](std::size_t b, const auto* src, std::size_t pitch) {
        placeBrick(h, b, level, a, e, out, outDims, src, pitch, deferred ? none : corrections[b]);
    };
    // Uniform bricks are filled with their value, not decoded: each filter's low band of a constant is that
    // constant, so this is exact at every level. Their payload checksums are still verified. `out` starts
    // zeroed (a new Volume, whose large blocks are untouched zero pages), so zero bricks are not written at
    // all. Before the output is handed to the device below.
    std::vector<std::size_t> varying, voxelCoded;
    std::vector<std::pair<std::size_t, V>> uniform;
    for (std::size_t b : which) {
        if (const std::optional<V> v = uniformValue<V>(h, h.bricks[frame][b]))
            uniform.emplace_back(b, *v);
        else if (voxelCodedBrick(file, h, frame, b))
            voxelCoded.push_back(b);
        else
            varying.push_back(b);
    }
    // Voxel-coded bricks are decoded and placed on host threads, also before the device sees the output.
    if (!voxelCoded.empty())
        timeStage(prof, &CodecProfile::entropy, [&] {
            parallelFor(voxelCoded.size(), threads, [&](std::size_t k) {
                placeVoxelBrick(file, h, frame, voxelCoded[k], level, a, e, out, outDims, name);
            });
        });
    if (!uniform.empty())
        timeStage(prof, &CodecProfile::assemble, [&] {
            parallelFor(uniform.size(), threads, [&](std::size_t k) {
                const auto [b, v] = uniform[k];
                vczBrickPayload(file, h, frame, b, name);
                if (v == V(0)) return;
                const auto [first, lo, hi] = brickBoxAt(h, b, level, a, e);
                for (std::size_t z = lo.z; z < hi.z; ++z)
                    for (std::size_t y = lo.y; y < hi.y; ++y) {
                        V* row = out.data() + ((z - a.z) * outDims.y + (y - a.y)) * outDims.x;
                        std::fill(row + (lo.x - a.x), row + (hi.x - a.x), v);
                    }
            });
        });
    // Whole bricks at full resolution: the inverse kernel may write the voxels itself while each brick is
    // in cache (CPU devices); then only the corrections are left for the host.
    std::optional<VoxelPlacement> toVoxels;
    if (placeOnDevice && level == 0 && h.transform != TransformKind::RawBits && !varying.empty() &&
        std::all_of(varying.begin(), varying.end(), [&](std::size_t b) {
            const Dims o = h.brickOrigin(b), d = h.brickDims(b);
            return o.x >= a.x && o.y >= a.y && o.z >= a.z && o.x + d.x <= e.x && o.y + d.y <= e.y &&
                   o.z + d.z <= e.z;
        }))
        toVoxels = VoxelPlacement{cc.wrapHost(out).get(), scalarTypeOf<V>(), outDims, a};
    // What a DecodeAhead decoded while the device started: the first rounds' batches, some or all filled.
    codec::AheadHandover pre;
    if (ahead && level == 0 && !deferred) {
        pre = ahead->take(file, frame, varying);
        for (std::size_t b = 0; b < pre.corrections.size() && b < n; ++b)
            if (!pre.corrections[b].empty()) corrections[b] = std::move(pre.corrections[b]);
    }
    std::vector<PrefilledRound>* prefilled = pre.rounds.empty() ? nullptr : &pre.rounds;
    bool placedOnDevice = false;
    if (varying.empty()) {
        // Every brick was uniform.
    } else if (h.transform == TransformKind::IntegerLifting) {
        // Decoded straight into the batch.
        LiftingTransform<std::int32_t> t(cc, h.wavelet);
        placedOnDevice =
            inverseBricks(cc, t, h, varying, level, threads, prof, {{&CodecProfile::entropy, entropyDecode}},
                          &CodecProfile::assemble, place, toVoxels ? &*toVoxels : nullptr, prefilled);
    } else if (h.transform == TransformKind::FloatLifting) {
        // Quantisation indices are decoded into the batch slot as int32 and dequantised there in place (the
        // entropy stage includes it): no separate index array.
        LiftingTransform<float> t(cc, h.wavelet);
        placedOnDevice =
            inverseBricks(cc, t, h, varying, level, threads, prof,
                          {{&CodecProfile::entropy,
                            [&](std::size_t b, float* dst, std::size_t pitch) {
                                entropyDecode(b, reinterpret_cast<std::int32_t*>(dst), pitch);
                            }}},
                          &CodecProfile::assemble, place, toVoxels ? &*toVoxels : nullptr, prefilled);
    } else {
        timeStage(prof, &CodecProfile::entropy, [&] {
            parallelFor(varying.size(), threads, [&](std::size_t k) {
                const std::size_t b = varying[k];
                ints[b].resize(h.brickDims(b).count());
                entropyDecode(b, ints[b].data(), h.brickDims(b).x);
            });
        });
        timeStage(prof, &CodecProfile::assemble, [&] {
            parallelFor(varying.size(), threads, [&](std::size_t k) {
                const std::size_t b = varying[k];
                place(b, ints[b].data(), h.brickDims(b).x);
            });
        });
    }
    if (deferred) {
        *deferred = std::move(corrections);
        if (placedOnDevice) {
            // Mapping makes the kernel's writes visible in `out`.
            BatchMapping<V> m(cc.queue(), toVoxels->voxels, out.size(), CL_MAP_READ | CL_MAP_WRITE);
        }
    } else if (placedOnDevice)
        timeStage(prof, &CodecProfile::assemble, [&] {
            // Mapping makes the kernel's writes visible in `out` (no copy where the device works in it).
            BatchMapping<V> m(cc.queue(), toVoxels->voxels, out.size(), CL_MAP_READ | CL_MAP_WRITE);
            for (std::size_t b : which)
                applyCorrections(h, b, a, e, std::span<V>(m.data(), out.size()), outDims, corrections[b]);
        });
}

} // namespace

void decodeFrameBricks(ComputeContext& cc, std::span<const std::byte> file, const VczHeader& h,
                       std::size_t frame, const std::vector<std::size_t>& which, int level, unsigned threads,
                       const std::string& name, CodecProfile* prof, Dims a, Dims e, Volume& out, Dims outDims,
                       bool placeOnDevice, std::vector<std::vector<Correction>>* deferredCorrections,
                       DecodeAhead* ahead) {
    if (prof) prof->bricks += which.size();
    // Bricks cover disjoint parts of the output, so they are placed in parallel.
    visitTyped(out, [&](auto span) {
        decodeBricksInto(cc, file, h, frame, which, level, threads, name, prof, a, e, span, outDims,
                         placeOnDevice, deferredCorrections, ahead);
    });
}

} // namespace volcl::codec
