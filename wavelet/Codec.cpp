// Wavelet codec: brick planning, transforms on the device, quantisation and rate control, entropy coding
// on host threads, .vcz assembly, and validated region / level decoding.
#include "wavelet/Codec.hpp"

#include "host/Error.hpp"
#include "host/runtime/Timing.hpp"

#include <zstd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <numeric>
#include <thread>

namespace volcl {

namespace {

constexpr double kMaxQuantIndex = double(1 << 29); // keeps magnitude classes well inside the coder's range

// Runs fn(i) for i in [0, n) on up to `threads` threads; rethrows the first exception.
template <class Fn> void parallelFor(std::size_t n, unsigned threads, Fn fn) {
    threads = std::max(1u, std::min<unsigned>(threads, static_cast<unsigned>(std::max<std::size_t>(n, 1))));
    if (threads == 1) {
        for (std::size_t i = 0; i < n; ++i)
            fn(i);
        return;
    }
    std::atomic<std::size_t> next{0};
    std::exception_ptr error;
    std::mutex m;
    auto work = [&] {
        for (;;) {
            const std::size_t i = next.fetch_add(1);
            if (i >= n) return;
            try {
                fn(i);
            } catch (...) {
                std::lock_guard lock(m);
                if (!error) error = std::current_exception();
                next = n;
                return;
            }
        }
    };
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < threads; ++t)
        pool.emplace_back(work);
    work();
    for (auto& t : pool)
        t.join();
    if (error) std::rethrow_exception(error);
}

// Calls fn with the volume's typed span.
template <class V, class Fn> decltype(auto) visitTyped(V& v, Fn fn) { // V: Volume or const Volume
    switch (v.type()) {
    case ScalarType::UInt8:
        return fn(v.template values<std::uint8_t>());
    case ScalarType::UInt16:
        return fn(v.template values<std::uint16_t>());
    case ScalarType::Int16:
        return fn(v.template values<std::int16_t>());
    case ScalarType::Float32:
        return fn(v.template values<float>());
    }
    throw Error("internal: unknown scalar type");
}

// Converts a reconstructed value to the voxel type: round to nearest (even) and clamp for integers.
// Without a libm call: clamping first is equivalent (the bounds are integers) and keeps |v| < 2^22, where
// adding and subtracting 1.5 * 2^23 rounds exactly like std::nearbyint. The encoder's error check and the
// decoder's output both use this, so the bound is checked on what the decoder writes.
template <class T> T toVoxel(float v) {
    if constexpr (std::is_same_v<T, float>) {
        return v;
    } else {
        const float c =
            std::clamp(v, float(std::numeric_limits<T>::min()), float(std::numeric_limits<T>::max()));
        return static_cast<T>(static_cast<std::int32_t>((c + 12582912.0f) - 12582912.0f));
    }
}

// Min and max over the finite voxels and whether any voxel is NaN or Inf, in one typed pass on host threads
// (Volume::stats also builds moments and a histogram, which the codec does not need).
struct ValueRange {
    double min = 0, max = 0;
    bool nonFinite = false;
};
ValueRange valueRange(const Volume& v, unsigned threads) {
    constexpr std::size_t kParts = 16;
    struct Part {
        double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();
        bool nonFinite = false;
    };
    std::vector<Part> parts(kParts);
    const std::size_t n = v.voxelCount();
    visitTyped(v, [&](auto span) {
        using S = std::remove_const_t<typename decltype(span)::element_type>;
        parallelFor(kParts, threads, [&](std::size_t p) {
            const std::size_t b = n * p / kParts, e = n * (p + 1) / kParts;
            if (b == e) return;
            if constexpr (std::is_same_v<S, float>) {
                float lo = std::numeric_limits<float>::infinity(), hi = -lo;
                bool bad = false;
                for (std::size_t i = b; i < e; ++i) {
                    const float x = span[i];
                    if (!std::isfinite(x)) {
                        bad = true;
                        continue;
                    }
                    lo = std::min(lo, x);
                    hi = std::max(hi, x);
                }
                parts[p] = {lo, hi, bad};
            } else {
                S lo = span[b], hi = span[b];
                for (std::size_t i = b; i < e; ++i) {
                    const S x = span[i]; // value selects vectorise; std::min on references did not
                    lo = x < lo ? x : lo;
                    hi = x > hi ? x : hi;
                }
                parts[p] = {double(lo), double(hi), false};
            }
        });
    });
    ValueRange r;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (const Part& p : parts) {
        lo = std::min(lo, p.lo);
        hi = std::max(hi, p.hi);
        r.nonFinite = r.nonFinite || p.nonFinite;
    }
    if (lo <= hi) {
        r.min = lo;
        r.max = hi;
    }
    return r;
}

// Bricks of equal dims are transformed together in one batch.
struct BrickGroup {
    Dims dims;
    std::vector<std::size_t> bricks;
};
std::vector<BrickGroup> groupBricks(const VczHeader& h, const std::vector<std::size_t>& which) {
    std::vector<BrickGroup> groups;
    for (std::size_t b : which) {
        const Dims d = h.brickDims(b);
        auto it =
            std::find_if(groups.begin(), groups.end(), [&](const BrickGroup& g) { return g.dims == d; });
        if (it == groups.end()) {
            groups.push_back({d, {}});
            it = groups.end() - 1;
        }
        it->bricks.push_back(b);
    }
    return groups;
}

// Adds the wall time of fn() to one stage of the profile (when profiling).
template <class Fn> void timeStage(CodecProfile* p, double CodecProfile::*stage, Fn&& fn) {
    if (!p) {
        fn();
        return;
    }
    Stopwatch sw;
    fn();
    p->*stage += sw.milliseconds();
}

// Rows of `pitch` elements (a batch slot) -> a dense brick array (brick dims, x fastest).
template <class T> std::vector<T> denseBrick(Dims d, const T* src, std::size_t pitch) {
    std::vector<T> dense(d.count());
    for (std::size_t r = 0; r < d.y * d.z; ++r)
        std::copy_n(src + r * pitch, d.x, dense.data() + r * d.x);
    return dense;
}

// Voxels of one brick of the volume as T (dense brick layout).
template <class T> std::vector<T> brickVoxels(const Volume& v, const VczHeader& h, std::size_t brick) {
    const Dims o = h.brickOrigin(brick), d = h.brickDims(brick);
    std::vector<T> out(d.count());
    visitTyped(v, [&](auto src) {
        for (std::size_t z = 0; z < d.z; ++z)
            for (std::size_t y = 0; y < d.y; ++y) {
                const std::size_t s = v.index(o.x, o.y + y, o.z + z);
                T* dst = out.data() + (z * d.y + y) * d.x;
                for (std::size_t x = 0; x < d.x; ++x) {
                    if constexpr (std::is_same_v<T, std::int32_t> &&
                                  std::is_same_v<typename decltype(src)::element_type, const float>) {
                        std::int32_t bits;
                        std::memcpy(&bits, &src[s + x], 4);
                        dst[x] = bits;
                    } else {
                        dst[x] = static_cast<T>(src[s + x]);
                    }
                }
            }
    });
    return out;
}

// Writes the voxels of one brick, converted to T, straight into a batch layout with row pitch `pitch`;
// returns the brick's voxel min and max (values convert exactly: integers to int32, up to 16 bits to float).
template <class T>
std::pair<double, double> gatherBrick(const Volume& v, const VczHeader& h, std::size_t brick, T* dst,
                                      std::size_t pitch) {
    const Dims o = h.brickOrigin(brick), d = h.brickDims(brick);
    return visitTyped(v, [&](auto src) {
        using S = std::remove_const_t<typename decltype(src)::element_type>;
        S lo = src[v.index(o.x, o.y, o.z)], hi = lo;
        for (std::size_t z = 0; z < d.z; ++z)
            for (std::size_t y = 0; y < d.y; ++y) {
                const S* in = src.data() + v.index(o.x, o.y + y, o.z + z);
                T* out = dst + (z * d.y + y) * pitch;
                for (std::size_t x = 0; x < d.x; ++x) {
                    const S s = in[x];
                    out[x] = static_cast<T>(s);
                    lo = s < lo ? s : lo; // value selects vectorise; std::min on references did not
                    hi = s > hi ? s : hi;
                }
            }
        return std::pair<double, double>(double(lo), double(hi));
    });
}

// One step that writes a brick into its batch slot: fn(b, dst, pitch) with rows of `pitch` elements,
// timed as `stage`.
template <class T> struct FillStep {
    double CodecProfile::*stage;
    std::function<void(std::size_t, T*, std::size_t)> fn;
};

// Runs one transform over the listed bricks, batched by brick shape. The fill steps write each brick into
// its batch slot; run(batches, groups) transforms them all (one launch on CPUs) and returns true when it
// also delivered the result (as voxels, see VoxelPlacement); otherwise emit(b, src, pitch) reads it from the
// mapped batch (timed as `emitStage`), so no dense copy is made. Filling and emitting are each one
// parallel loop over all bricks of all batches (per-shape loops left a thread idle on shapes with a single
// brick), and a brick's fill steps run back to back, so later steps find the brick in cache.
template <class T, class Run, class Emit>
bool transformBricks(ComputeContext& cc, const VczHeader& h, const std::vector<std::size_t>& which,
                     unsigned threads, CodecProfile* prof, const std::vector<FillStep<T>>& fills, Run run,
                     double CodecProfile::*emitStage, Emit emit) {
    const std::vector<BrickGroup> groups = groupBricks(h, which);
    std::vector<std::unique_ptr<BrickBatch<T>>> batches;
    struct Slot {
        std::size_t brick, group, index;
    };
    std::vector<Slot> slots;
    for (std::size_t g = 0; g < groups.size(); ++g) {
        batches.push_back(std::make_unique<BrickBatch<T>>(cc, groups[g].dims, groups[g].bricks.size()));
        for (std::size_t i = 0; i < groups[g].bricks.size(); ++i)
            slots.push_back({groups[g].bricks[i], g, i});
    }
    std::vector<BatchMapping<T>> maps(groups.size());
    auto forEachSlot = [&](double CodecProfile::*stage, auto fn) {
        timeStage(prof, stage, [&] {
            parallelFor(slots.size(), threads, [&](std::size_t k) {
                const Slot& s = slots[k];
                fn(s.brick, maps[s.group].data() + s.index * batches[s.group]->brickStride(),
                   batches[s.group]->pitch());
            });
        });
    };
    // Without fill steps the transform fills the batches itself (forwardFromVoxels).
    if (!fills.empty()) {
        timeStage(prof, &CodecProfile::upload, [&] {
            for (std::size_t g = 0; g < groups.size(); ++g)
                maps[g] = batches[g]->mapForWrite(cc);
        });
        // Each fill stage gets the loop's wall time in proportion to its summed per-brick time.
        std::vector<double> stepMs(fills.size() * slots.size(), 0.0);
        Stopwatch wall;
        parallelFor(slots.size(), threads, [&](std::size_t k) {
            const Slot& s = slots[k];
            T* dst = maps[s.group].data() + s.index * batches[s.group]->brickStride();
            for (std::size_t f = 0; f < fills.size(); ++f) {
                Stopwatch sw;
                fills[f].fn(s.brick, dst, batches[s.group]->pitch());
                if (prof) stepMs[f * slots.size() + k] = sw.milliseconds();
            }
            // The kernels' full-width vector steps compute on row padding too: keep it zero, since pooled
            // memory may hold old integers there, which read as floats are denormals (an assist per vector
            // instruction on x86). A precaution: no speed difference was measurable under load. (The slack
            // after the last brick is left alone: only the last row's vector reads reach it, and zeroing it
            // cost two fill commands per batch.)
            const Dims d = groups[s.group].dims;
            const std::size_t pitch = batches[s.group]->pitch();
            if (pitch > d.x)
                for (std::size_t r = 0; r < d.y * d.z; ++r)
                    std::fill(dst + r * pitch + d.x, dst + (r + 1) * pitch, T(0));
        });
        if (prof) {
            const double ms = wall.milliseconds();
            std::vector<double> perStep(fills.size(), 0.0);
            for (std::size_t f = 0; f < fills.size(); ++f)
                for (std::size_t k = 0; k < slots.size(); ++k)
                    perStep[f] += stepMs[f * slots.size() + k];
            const double sum = std::accumulate(perStep.begin(), perStep.end(), 0.0);
            for (std::size_t f = 0; f < fills.size(); ++f)
                prof->*(fills[f].stage) += sum > 0 ? ms * perStep[f] / sum : ms / double(fills.size());
        }
        timeStage(prof, &CodecProfile::upload, [&] {
            for (auto& m : maps)
                m.unmap();
        });
    }
    std::vector<BrickBatch<T>*> all;
    for (auto& b : batches)
        all.push_back(b.get());
    bool emitted = false;
    timeStage(prof, &CodecProfile::transform,
              [&] { emitted = run(std::span<BrickBatch<T>* const>(all), groups); });
    if (emitted) return true;
    timeStage(prof, &CodecProfile::download, [&] {
        for (std::size_t g = 0; g < groups.size(); ++g)
            maps[g] = batches[g]->mapForRead(cc);
    });
    forEachSlot(emitStage, [&](std::size_t b, T* src, std::size_t pitch) { emit(b, static_cast<const T*>(src), pitch); });
    return false;
}

std::vector<std::size_t> allBricks(const VczHeader& h) {
    std::vector<std::size_t> all(h.brickCount());
    for (std::size_t i = 0; i < all.size(); ++i)
        all[i] = i;
    return all;
}

// Each brick's first voxel relative to `first`, per batch group (VoxelVolume::origins).
std::vector<std::vector<Dims>> brickOrigins(const VczHeader& h, const std::vector<BrickGroup>& groups,
                                            Dims first) {
    std::vector<std::vector<Dims>> origins;
    for (const BrickGroup& g : groups) {
        auto& o = origins.emplace_back();
        for (std::size_t brick : g.bricks) {
            const Dims bo = h.brickOrigin(brick);
            o.push_back({bo.x - first.x, bo.y - first.y, bo.z - first.z});
        }
    }
    return origins;
}

// Forward transform of every brick: emit(b, coefficients, pitch) sees each brick's coefficients in the mapped
// batch. Adds kernel time to `ms` and, with `ranges`, stores each brick's voxel min and max (gathered on the
// way).
template <class T, class Emit>
void forwardBricks(ComputeContext& cc, LiftingTransform<T>& t, const Volume& v, const VczHeader& h,
                   unsigned threads, CodecProfile* prof, double& ms, std::vector<std::pair<double, double>>* ranges,
                   double CodecProfile::*emitStage, Emit emit) {
    if (ranges) ranges->assign(h.brickCount(), {0.0, 0.0});
    // On the brick-resident path the kernel reads each brick's voxels itself, so the brick is in cache for
    // its first level and no host pass writes the batch (the integer transform takes integer voxels only).
    const bool fromVoxels = h.levels > 0 && t.pathFor(h.brick) == LiftingPath::BrickResident &&
                            (std::is_same_v<T, float> || v.type() != ScalarType::Float32);
    std::vector<FillStep<T>> fills;
    if (!fromVoxels)
        fills.push_back({&CodecProfile::gather, [&](std::size_t b, T* dst, std::size_t pitch) {
                             const auto r = gatherBrick<T>(v, h, b, dst, pitch);
                             if (ranges) (*ranges)[b] = r;
                         }});
    transformBricks<T>(
        cc, h, allBricks(h), threads, prof, fills,
        [&](std::span<BrickBatch<T>* const> b, const std::vector<BrickGroup>& groups) {
            if (!fromVoxels) {
                ms += t.forward(cc, b, h.levels);
                return false;
            }
            auto bytes = const_cast<Volume&>(v).bytes(); // read only (CL_MEM_READ_ONLY)
            const VoxelVolume source{cc.wrapHost(bytes, CL_MEM_READ_ONLY).get(), v.type(), v.dims(),
                                     brickOrigins(h, groups, {0, 0, 0})};
            std::vector<std::vector<std::pair<double, double>>> r;
            ms += t.forwardFromVoxels(cc, b, h.levels, source, ranges ? &r : nullptr);
            if (ranges)
                for (std::size_t g = 0; g < groups.size(); ++g)
                    for (std::size_t i = 0; i < groups[g].bricks.size(); ++i)
                        (*ranges)[groups[g].bricks[i]] = r[g][i];
            return false;
        },
        emitStage, emit);
}

// An output volume the inverse kernel may write voxels into directly: `voxels` over its memory, holding
// the full-resolution box that starts at `first`.
struct VoxelPlacement {
    cl::Buffer voxels;
    ScalarType type;
    Dims dims, first;
};

// Inverse transform of the listed bricks down to `level` (see transformBricks for fill and emit). With
// `toVoxels`, a full-resolution inverse on the brick-resident path writes the voxels from the kernel, emit
// is not called and the result is true (every listed brick must lie inside the placement's box); the host
// must map the placement's buffer before reading them.
template <class T, class Emit>
bool inverseBricks(ComputeContext& cc, LiftingTransform<T>& t, const VczHeader& h,
                   const std::vector<std::size_t>& which, int level, unsigned threads, CodecProfile* prof,
                   const std::vector<FillStep<T>>& fills, double CodecProfile::*emitStage, Emit emit,
                   const VoxelPlacement* toVoxels = nullptr) {
    return transformBricks<T>(
        cc, h, which, threads, prof, fills,
        [&](std::span<BrickBatch<T>* const> b, const std::vector<BrickGroup>& groups) {
            if (toVoxels && level == 0 && t.canUseVoxels(b)) {
                t.inverseToVoxels(cc, b, h.levels,
                                  {toVoxels->voxels, toVoxels->type, toVoxels->dims,
                                   brickOrigins(h, groups, toVoxels->first)});
                return true;
            }
            t.inverse(cc, b, h.levels, level);
            return false;
        },
        emitStage, emit);
}

// ------------------------------------------------------------------------------ quantisation

// L2 norm of the 1D synthesis basis function of a level-l low or high coefficient.
double synthesisGain(Wavelet w, int level, bool high) {
    const std::size_t n = 1024;
    std::vector<double> line(n, 0.0);
    const std::size_t lowLen = n >> level, highLen = (n >> (level - 1)) - lowLen;
    line[high ? lowLen + highLen / 2 : lowLen / 2] = 1.0;
    reference::inverse3d(std::span<double>(line), {n, 1, 1}, level, w);
    double s = 0;
    for (double v : line)
        s += v * v;
    return std::sqrt(s);
}

// Per-subband steps: a coefficient error e costs about e * gain in the voxel domain, so step = delta / gain.
std::vector<double> subbandSteps(Wavelet w, int levels, double delta) {
    std::vector<double> steps;
    if (levels == 0) return {delta};
    const double lowGain = synthesisGain(w, levels, false);
    steps.push_back(delta / (lowGain * lowGain * lowGain));
    for (int l = 1; l <= levels; ++l) {
        const double gl = synthesisGain(w, l, false), gh = synthesisGain(w, l, true);
        for (int o = 1; o < 8; ++o) {
            const double g = ((o & 1) ? gh : gl) * ((o & 2) ? gh : gl) * ((o & 4) ? gh : gl);
            steps.push_back(delta / g);
        }
    }
    return steps;
}

// Calls fn(z, y, x0, length, step) for every row of every subband of a brick of dims d: per-row loops with
// one step vectorise, per-coefficient callbacks did not.
template <class Fn> void forEachSubbandRow(const VczHeader& h, Dims d, Fn fn) {
    for (const auto& sec : sectionLayout(d, h.levels))
        for (const SubbandBox& b : sec) {
            const double step = h.step(b.level, b.orient);
            for (std::size_t z = b.z0; z < b.z1; ++z)
                for (std::size_t y = b.y0; y < b.y1; ++y)
                    fn(z, y, b.x0, b.x1 - b.x0, step);
        }
}

// Dead-zone quantiser q = sign(c) floor(|c| / step), in float with the reciprocal step (truncation is floor
// for |c| >= 0). Only the encoder quantises and it checks what the decoder will reconstruct from q, so a
// rounding difference at a cell boundary cannot break a bound.
void quantiseRow(const float* in, std::int32_t* out, std::size_t len, double step) {
    const float inv = static_cast<float>(1.0 / step), cap = static_cast<float>(kMaxQuantIndex);
    for (std::size_t i = 0; i < len; ++i) {
        const auto m = static_cast<std::int32_t>(std::min(std::abs(in[i]) * inv, cap));
        out[i] = in[i] < 0 ? -m : m;
    }
}

// Quantisation indices of a brick of coefficients in rows of `pitch` into `q` (dense brick layout).
void quantiseInto(const VczHeader& h, Dims d, const float* c, std::size_t pitch, std::int32_t* q) {
    forEachSubbandRow(h, d, [&](std::size_t z, std::size_t y, std::size_t x0, std::size_t len, double step) {
        quantiseRow(c + (z * d.y + y) * pitch + x0, q + (z * d.y + y) * d.x + x0, len, step);
    });
}

// What the decoder will reconstruct from a dense brick of coefficients quantised with the header's steps,
// written to rows of `pitch`: quantised and dequantised row by row, with no index array.
void requantiseInto(const VczHeader& h, Dims d, const float* c, float* dst, std::size_t pitch) {
    std::array<std::int32_t, 1024> q; // a brick row is at most 1024 (Encoder::plan)
    forEachSubbandRow(h, d, [&](std::size_t z, std::size_t y, std::size_t x0, std::size_t len, double step) {
        quantiseRow(c + (z * d.y + y) * d.x + x0, q.data(), len, step);
        dequantiseRow(q.data(), dst + (z * d.y + y) * pitch + x0, len, step, h.reconstructionBias);
    });
}

// ------------------------------------------------------------------------------ brick payloads

struct Correction {
    std::uint32_t index;
    double value;
};

void putVarint(std::vector<std::uint8_t>& out, std::uint64_t v) {
    while (v >= 0x80) {
        out.push_back(static_cast<std::uint8_t>(v | 0x80));
        v >>= 7;
    }
    out.push_back(static_cast<std::uint8_t>(v));
}
std::uint64_t getVarint(std::span<const std::uint8_t> in, std::size_t& pos, const std::string& what) {
    std::uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
        if (pos >= in.size()) throw IoError(what + ": truncated corrections");
        const std::uint8_t b = in[pos++];
        v |= std::uint64_t(b & 0x7f) << shift;
        if (!(b & 0x80)) return v;
    }
    throw IoError(what + ": invalid corrections");
}

std::vector<std::uint8_t> encodeCorrections(const std::vector<Correction>& corr, ScalarType type) {
    std::vector<std::uint8_t> raw;
    putVarint(raw, corr.size());
    std::uint32_t prev = 0;
    for (const Correction& c : corr) {
        putVarint(raw, c.index - prev);
        prev = c.index;
        std::uint8_t bytes[4];
        switch (type) {
        case ScalarType::UInt8:
            bytes[0] = static_cast<std::uint8_t>(c.value);
            break;
        case ScalarType::UInt16: {
            auto v = static_cast<std::uint16_t>(c.value);
            std::memcpy(bytes, &v, 2);
            break;
        }
        case ScalarType::Int16: {
            auto v = static_cast<std::int16_t>(c.value);
            std::memcpy(bytes, &v, 2);
            break;
        }
        case ScalarType::Float32: {
            auto v = static_cast<float>(c.value);
            std::memcpy(bytes, &v, 4);
            break;
        }
        }
        raw.insert(raw.end(), bytes, bytes + scalarSize(type));
    }
    std::vector<std::uint8_t> out(ZSTD_compressBound(raw.size()));
    const std::size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), 3);
    if (ZSTD_isError(n)) throw Error(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    out.resize(n);
    return out;
}

std::vector<Correction> decodeCorrections(std::span<const std::uint8_t> in, ScalarType type,
                                          std::size_t brickVoxels, const std::string& what) {
    const unsigned long long size = ZSTD_getFrameContentSize(in.data(), in.size());
    const std::size_t maxSize = 10 + brickVoxels * (5 + scalarSize(type));
    if (size == ZSTD_CONTENTSIZE_ERROR || size == ZSTD_CONTENTSIZE_UNKNOWN || size > maxSize)
        throw IoError(what + ": invalid corrections");
    std::vector<std::uint8_t> raw(size);
    const std::size_t n = ZSTD_decompress(raw.data(), raw.size(), in.data(), in.size());
    if (ZSTD_isError(n) || n != raw.size()) throw IoError(what + ": invalid corrections");
    std::size_t pos = 0;
    const std::uint64_t count = getVarint(raw, pos, what);
    if (count > brickVoxels) throw IoError(what + ": invalid corrections");
    std::vector<Correction> out(count);
    std::uint64_t index = 0;
    for (Correction& c : out) {
        index += getVarint(raw, pos, what);
        if (index >= brickVoxels || raw.size() - pos < scalarSize(type))
            throw IoError(what + ": invalid corrections");
        c.index = static_cast<std::uint32_t>(index);
        const std::uint8_t* b = raw.data() + pos;
        switch (type) {
        case ScalarType::UInt8:
            c.value = b[0];
            break;
        case ScalarType::UInt16: {
            std::uint16_t v;
            std::memcpy(&v, b, 2);
            c.value = v;
            break;
        }
        case ScalarType::Int16: {
            std::int16_t v;
            std::memcpy(&v, b, 2);
            c.value = v;
            break;
        }
        case ScalarType::Float32: {
            float v;
            std::memcpy(&v, b, 4);
            c.value = v;
            break;
        }
        }
        pos += scalarSize(type);
    }
    return out;
}

// Payload: u8 section count, u8 flags (bit 0: corrections), u32 size per section, u32 corrections size, data.
// `q` holds the brick's coefficients in rows of `pitch` elements (0: dense, pitch d.x).
std::vector<std::uint8_t> buildPayload(const VczHeader& h, Dims d, std::span<const std::int32_t> q,
                                       const std::vector<Correction>& corr, std::size_t pitch = 0) {
    const int levels = h.transform == TransformKind::RawBits ? 0 : h.levels;
    const auto layout = sectionLayout(d, levels);
    const Dims storage{pitch ? pitch : d.x, d.y, d.z};
    std::vector<std::vector<std::uint8_t>> sections(layout.size());
    for (std::size_t s = 0; s < layout.size(); ++s)
        encodeSection(q, storage, layout, s, h.entropy, sections[s]);
    std::vector<std::uint8_t> corrBytes;
    if (!corr.empty()) corrBytes = encodeCorrections(corr, h.type);
    std::vector<std::uint8_t> out;
    out.push_back(static_cast<std::uint8_t>(layout.size()));
    out.push_back(corr.empty() ? 0 : 1);
    auto put32 = [&](std::size_t v) {
        const auto u = static_cast<std::uint32_t>(v);
        out.insert(out.end(), reinterpret_cast<const std::uint8_t*>(&u),
                   reinterpret_cast<const std::uint8_t*>(&u) + 4);
    };
    for (const auto& s : sections)
        put32(s.size());
    put32(corrBytes.size());
    for (const auto& s : sections)
        out.insert(out.end(), s.begin(), s.end());
    out.insert(out.end(), corrBytes.begin(), corrBytes.end());
    return out;
}

struct ParsedPayload {
    std::vector<std::span<const std::uint8_t>> sections;
    std::span<const std::uint8_t> corrections;
};
ParsedPayload parsePayload(std::span<const std::uint8_t> p, std::size_t expectedSections,
                           const std::string& what) {
    if (p.size() < 2 || p[0] != expectedSections || p[1] > 1) throw IoError(what + ": invalid brick header");
    std::size_t pos = 2;
    auto get32 = [&]() -> std::size_t {
        if (p.size() - pos < 4) throw IoError(what + ": truncated brick header");
        std::uint32_t v;
        std::memcpy(&v, p.data() + pos, 4);
        pos += 4;
        return v;
    };
    std::vector<std::size_t> sizes(expectedSections + 1);
    for (auto& s : sizes)
        s = get32();
    ParsedPayload out;
    for (std::size_t i = 0; i <= expectedSections; ++i) {
        if (sizes[i] > p.size() - pos) throw IoError(what + ": section sizes exceed the brick");
        auto span = p.subspan(pos, sizes[i]);
        pos += sizes[i];
        if (i < expectedSections)
            out.sections.push_back(span);
        else
            out.corrections = span;
    }
    if (pos != p.size()) throw IoError(what + ": unexpected bytes after the brick data");
    if ((p[1] == 1) != !out.corrections.empty()) throw IoError(what + ": inconsistent corrections flag");
    return out;
}

// ------------------------------------------------------------------------------ encoder

struct FrameResult {
    std::vector<std::vector<std::uint8_t>> payloads;
    std::vector<std::pair<double, double>> ranges;
    EncodeReport report;
};

struct ErrorStats {
    double sumSq = 0, maxErr = 0;
};

class Encoder {
public:
    Encoder(ComputeContext& cc, const CodecOptions& o) : cc_(cc), o_(o) {}

    VczHeader plan(const Volume& v) {
        if (v.empty()) throw UsageError("cannot encode an empty volume");
        if (o_.levels < 0 || o_.levels > 8) throw UsageError("--levels must be between 0 and 8");
        const std::size_t m = std::size_t(1) << o_.levels;
        for (std::size_t b : {o_.brick.x, o_.brick.y, o_.brick.z})
            if (b == 0 || b % m != 0 || b > 1024)
                throw UsageError("--brick must be a positive multiple of 2^levels (" + std::to_string(m) +
                                 ") up to 1024");
        VczHeader h;
        h.dims = v.dims();
        h.type = v.type();
        h.spacing = v.spacing;
        h.origin = v.origin;
        h.levels = o_.levels;
        h.brick = o_.brick;
        h.entropy = o_.entropy;
        h.rate = o_.rate;
        h.rateTarget = o_.target;
        h.metadata = o_.metadata;
        const bool integer = v.type() != ScalarType::Float32;
        if (o_.rate == RateMode::Lossless) {
            h.wavelet = o_.wavelet.value_or(Wavelet::Cdf53);
            if (!hasIntegerForm(h.wavelet))
                throw UsageError("--lossless needs a reversible wavelet: cdf53, haar or cdf26");
            if (integer) {
                h.transform = TransformKind::IntegerLifting;
            } else {
                // Float voxels are kept bit for bit (NaN and Inf included): no transform, byte planes + zstd.
                h.transform = TransformKind::RawBits;
                h.entropy = EntropyMode::Fast;
                h.levels = 0;
            }
        } else {
            h.wavelet = o_.wavelet.value_or(Wavelet::Cdf97);
            h.transform = TransformKind::FloatLifting;
            if (!(o_.target > 0) || !std::isfinite(o_.target))
                throw UsageError("the rate target must be a positive number");
            if (o_.rate == RateMode::MaxError && integer && o_.target < 1.0) {
                // An integer volume within |error| < 1 is the volume itself.
                h.rate = RateMode::Lossless;
                h.wavelet = o_.wavelet && hasIntegerForm(*o_.wavelet) ? *o_.wavelet : Wavelet::Cdf53;
                h.transform = TransformKind::IntegerLifting;
            }
        }
        h.frames.resize(1);
        return h;
    }

    FrameResult encodeFrame(const Volume& v, VczHeader& h, bool chooseStep) {
        if (h.transform == TransformKind::IntegerLifting) return encodeLossless(v, h);
        if (h.transform == TransformKind::RawBits) return encodeRaw(v, h);
        return encodeLossy(v, h, chooseStep);
    }

    /// The volume's value range, scanned once per volume (encodeVolume and the lossy path both need it).
    const ValueRange& rangeOf(const Volume& v) {
        if (rangeOf_ != &v) {
            range_ = valueRange(v, o_.threads);
            rangeOf_ = &v;
        }
        return range_;
    }

private:
    std::vector<std::pair<double, double>> brickRanges(const Volume& v, const VczHeader& h) {
        std::vector<std::pair<double, double>> r(h.brickCount());
        parallelFor(r.size(), o_.threads, [&](std::size_t b) {
            const auto vox = brickVoxels<double>(v, h, b);
            double lo = std::numeric_limits<double>::infinity(), hi = -lo;
            for (double x : vox)
                if (!std::isnan(x)) {
                    lo = std::min(lo, x);
                    hi = std::max(hi, x);
                }
            if (lo > hi) lo = hi = 0;
            r[b] = {lo, hi};
        });
        return r;
    }

    FrameResult encodeLossless(const Volume& v, VczHeader& h) {
        LiftingTransform<std::int32_t> t(cc_, h.wavelet);
        FrameResult r;
        CodecProfile* prof = &r.report.profile;
        r.payloads.resize(h.brickCount());
        // Coded straight from the mapped batch.
        forwardBricks<std::int32_t>(cc_, t, v, h, o_.threads, prof, r.report.transformMs, &r.ranges,
                                    &CodecProfile::entropy,
                                    [&](std::size_t b, const std::int32_t* c, std::size_t pitch) {
                                        const Dims d = h.brickDims(b);
                                        r.payloads[b] = buildPayload(h, d, {c, pitch * d.y * d.z}, {}, pitch);
                                    });
        r.report.psnr = std::numeric_limits<double>::infinity();
        return r;
    }

    FrameResult encodeRaw(const Volume& v, VczHeader& h) {
        FrameResult r;
        r.payloads.resize(h.brickCount());
        timeStage(&r.report.profile, &CodecProfile::entropy, [&] {
            parallelFor(r.payloads.size(), o_.threads, [&](std::size_t b) {
                const auto bits = brickVoxels<std::int32_t>(v, h, b);
                r.payloads[b] = buildPayload(h, h.brickDims(b), bits, {});
            });
        });
        timeStage(&r.report.profile, &CodecProfile::assemble, [&] { r.ranges = brickRanges(v, h); });
        r.report.psnr = std::numeric_limits<double>::infinity();
        return r;
    }

    // Quantises with the header's steps, reconstructs like the decoder and measures the error;
    // with `bound` it also lists the voxels to store exactly.
    struct Trial {
        std::vector<std::vector<Correction>> corrections;
        ErrorStats err;
    };
    // With `reconstruct` false only the quantisation runs (a fixed-step encode whose error is not wanted).
    Trial trial(const Volume& v, const VczHeader& h, LiftingTransform<float>& t,
                const std::vector<std::vector<float>>& coeffs, std::optional<double> bound,
                CodecProfile* prof, bool reconstruct = true) {
        Trial tr;
        const std::size_t n = coeffs.size();
        tr.corrections.resize(n);
        ++prof->trials;
        if (!reconstruct) {
            tr.err.sumSq = tr.err.maxErr = std::numeric_limits<double>::quiet_NaN();
            return tr;
        }
        timeStage(prof, &CodecProfile::reconstruct, [&] {
            std::vector<ErrorStats> es(n);
            inverseBricks(
                cc_, t, h, allBricks(h), 0, o_.threads, nullptr,
                {{&CodecProfile::reconstruct,
                  [&](std::size_t b, float* dst, std::size_t pitch) {
                      requantiseInto(h, h.brickDims(b), coeffs[b].data(), dst, pitch);
                  }}},
                &CodecProfile::reconstruct, [&](std::size_t b, const float* rec, std::size_t pitch) {
                    const Dims o = h.brickOrigin(b), d = h.brickDims(b);
                    double sumSq = 0, maxErr = 0;
                    visitTyped(v, [&](auto span) {
                        using V = std::remove_const_t<typename decltype(span)::element_type>;
                        for (std::size_t z = 0; z < d.z; ++z)
                            for (std::size_t y = 0; y < d.y; ++y) {
                                const V* in = span.data() + v.index(o.x, o.y + y, o.z + z);
                                const float* r = rec + (z * d.y + y) * pitch;
                                for (std::size_t x = 0; x < d.x; ++x) {
                                    const double orig = double(in[x]);
                                    const double e = std::abs(double(toVoxel<V>(r[x])) - orig);
                                    if (bound && e > *bound) {
                                        tr.corrections[b].push_back(
                                            {static_cast<std::uint32_t>((z * d.y + y) * d.x + x), orig});
                                        continue;
                                    }
                                    sumSq += e * e;
                                    maxErr = std::max(maxErr, e);
                                }
                            }
                    });
                    es[b] = {sumSq, maxErr};
                });
            for (const auto& e : es) {
                tr.err.sumSq += e.sumSq;
                tr.err.maxErr = std::max(tr.err.maxErr, e.maxErr);
            }
        });
        return tr;
    }

    // Quantises each brick into a per-thread index array (reused, cache-resident) and codes it.
    std::size_t codedBytes(const VczHeader& h, const std::vector<std::vector<float>>& coeffs, const Trial& tr,
                           std::vector<std::vector<std::uint8_t>>* payloads, CodecProfile* prof) {
        std::vector<std::vector<std::uint8_t>> p(coeffs.size());
        timeStage(prof, &CodecProfile::entropy, [&] {
            parallelFor(p.size(), o_.threads, [&](std::size_t b) {
                thread_local std::vector<std::int32_t> q;
                const Dims d = h.brickDims(b);
                q.resize(d.count());
                quantiseInto(h, d, coeffs[b].data(), d.x, q.data());
                p[b] = buildPayload(h, d, q, tr.corrections[b]);
            });
        });
        std::size_t total = vczPreambleSize(h);
        for (const auto& x : p)
            total += x.size();
        if (payloads) *payloads = std::move(p);
        return total;
    }

    FrameResult encodeLossy(const Volume& v, VczHeader& h, bool chooseStep) {
        const ValueRange st = rangeOf(v);
        if (st.nonFinite)
            throw DataError(
                "lossy encoding needs finite voxels (found NaN/Inf): use --lossless to keep them exactly");
        LiftingTransform<float> t(cc_, h.wavelet);
        if (o_.step && chooseStep && (!(*o_.step > 0) || !std::isfinite(*o_.step)))
            throw UsageError("the quantiser step must be a positive number");
        if ((!chooseStep || o_.step) && h.rate != RateMode::MaxError && !o_.measureError)
            if (std::optional<FrameResult> r = encodeDirect(v, h, t, chooseStep ? o_.step : std::nullopt))
                return std::move(*r);
        FrameResult r;
        CodecProfile* prof = &r.report.profile;
        std::vector<std::vector<float>> coeffs(h.brickCount());
        const std::size_t nsub = 1 + 7 * std::size_t(h.levels);
        std::vector<std::int32_t> brickMax(h.brickCount() * nsub, 0);
        forwardBricks<float>(cc_, t, v, h, o_.threads, prof, r.report.transformMs, &r.ranges,
                             &CodecProfile::gather, [&](std::size_t b, const float* c, std::size_t pitch) {
                                 coeffs[b] = denseBrick(h.brickDims(b), c, pitch);
                                 subbandMaxAbs(h, h.brickDims(b), coeffs[b].data(), h.brickDims(b).x,
                                               &brickMax[b * nsub]);
                             });
        const std::vector<double> maxAbs = mergeMaxima(brickMax, nsub);
        const double range = st.max - st.min;
        const double n = double(v.voxelCount());
        const double rangeSq = range * range;
        double lastDelta = 0, bestDelta = 0;
        auto setDelta = [&](double delta) {
            lastDelta = delta;
            h.steps = subbandSteps(h.wavelet, h.levels, delta);
            // Keeps quantisation indices inside the coder's range for data of huge dynamic range.
            for (std::size_t i = 0; i < h.steps.size(); ++i)
                h.steps[i] = std::max(h.steps[i], maxAbs[i] / (kMaxQuantIndex - 2));
        };
        Trial best;
        if (o_.step && chooseStep) {
            setDelta(*o_.step);
            chooseStep = false;
        }
        if (!chooseStep) {
            bestDelta = lastDelta;
            const bool bounded = h.rate == RateMode::MaxError;
            best = trial(v, h, t, coeffs, bounded ? std::optional(o_.target) : std::nullopt, prof,
                         bounded || o_.measureError);
        } else if (h.rate == RateMode::MaxError) {
            // Larger steps leave more voxels to store exactly: keep the candidate with the smallest file.
            std::size_t bestBytes = std::numeric_limits<std::size_t>::max();
            std::vector<double> bestSteps;
            for (double k : {0.9, 1.4, 2.0, 2.8}) {
                setDelta(k * o_.target);
                Trial tr = trial(v, h, t, coeffs, o_.target, prof);
                const std::size_t bytes = codedBytes(h, coeffs, tr, nullptr, prof);
                if (bytes < bestBytes) {
                    bestBytes = bytes;
                    best = std::move(tr);
                    bestSteps = h.steps;
                    bestDelta = lastDelta;
                }
            }
            h.steps = bestSteps;
        } else {
            // Search on x = log2(delta): PSNR and size both fall as x grows. Keeps the largest x with PSNR >=
            // P (done once PSNR < P + 0.25) or the smallest with size <= R bits/voxel (done once size >= 0.99
            // R). Secant steps between the nearest trials on either side of the window (bisection when a step
            // would leave the bracket) reach it in 3-5 trials where bisection from a guess took 8-11. Rate
            // trials only entropy code (no reconstruction); the kept trial's payloads are reused.
            const bool psnrMode = h.rate == RateMode::Psnr;
            const double guess =
                psnrMode ? std::log2(std::max(range, 1e-30) * std::pow(10.0, -o_.target / 20) * 3.0)
                         : std::log2(std::max(range, 1e-30)) - 2 * o_.target;
            const double wlo = psnrMode ? o_.target : 0.99 * o_.target;
            const double whi = psnrMode ? o_.target + 0.25 : o_.target;
            const double aim = 0.5 * (wlo + whi);
            // Interpolation runs on PSNR (linear in x) or on log(size) (closer to linear than size).
            auto f = [psnrMode](double q) { return psnrMode ? q : std::log(std::max(q, 1e-12)); };
            double lo = guess - 40, hi = guess + 40, qlo = 0, qhi = 0;
            bool haveLo = false, haveHi = false, found = false;
            double bestX = 0, prevX = 0, prevQ = 0;
            bool havePrev = false;
            std::vector<double> bestSteps;
            std::vector<std::vector<std::uint8_t>> bestPayloads;
            double x = range == 0 ? guess + 8 : guess; // a constant volume meets any PSNR
            for (int it = 0; it < 30; ++it) {
                setDelta(std::exp2(x));
                Trial tr = trial(v, h, t, coeffs, std::nullopt, prof, psnrMode);
                std::vector<std::vector<std::uint8_t>> payloads;
                double q;
                bool ok;
                if (psnrMode) {
                    const double mse = tr.err.sumSq / n;
                    q = mse == 0 ? std::numeric_limits<double>::infinity() : 10 * std::log10(rangeSq / mse);
                    ok = range == 0 || q >= o_.target;
                } else {
                    q = double(codedBytes(h, coeffs, tr, &payloads, prof)) * 8 / n;
                    ok = q <= o_.target;
                }
                if (ok && (!found || (psnrMode ? x > bestX : x < bestX))) {
                    found = true;
                    bestX = x;
                    best = std::move(tr);
                    bestSteps = h.steps;
                    bestDelta = lastDelta;
                    bestPayloads = std::move(payloads);
                }
                if (range == 0 || (q >= wlo && q <= whi)) break;
                if (q > whi) {
                    lo = x;
                    qlo = q;
                    haveLo = true;
                } else {
                    hi = x;
                    qhi = q;
                    haveHi = true;
                }
                if (hi - lo < 0.02) break;
                double next;
                if (haveLo && haveHi) {
                    // Interpolate inside the bracket (bisect next to an exact trial), away from its ends so
                    // that it keeps shrinking.
                    next = std::isfinite(qlo) ? lo + (f(qlo) - f(aim)) * (hi - lo) / (f(qlo) - f(qhi))
                                              : 0.5 * (lo + hi);
                    const double margin = 0.05 * (hi - lo);
                    next = std::clamp(next, lo + margin, hi - margin);
                } else {
                    if (std::isfinite(q) && havePrev && std::isfinite(prevQ) && prevQ != q) {
                        next = x + (f(aim) - f(q)) * (x - prevX) / (f(q) - f(prevQ));
                    } else {
                        // First step or an exact (infinite PSNR) trial: PSNR drops ~6 dB and log(size) ~0.5
                        // per doubling of the step.
                        const double slope = psnrMode ? -6.02 : -0.5;
                        next = std::isfinite(q) ? x + (f(aim) - f(q)) / slope : x + 2;
                    }
                    next = std::clamp(next, lo + 0.01, hi - 0.01);
                }
                prevX = x;
                prevQ = q;
                havePrev = true;
                x = next;
            }
            if (!found) {
                if (!psnrMode)
                    throw UsageError("--bpv " + std::to_string(o_.target) +
                                     " is below what this volume can be coded in");
                setDelta(std::exp2(guess - 40));
                best = trial(v, h, t, coeffs, std::nullopt, prof);
                bestSteps = h.steps;
                bestDelta = lastDelta;
            }
            h.steps = bestSteps;
            if (!psnrMode) {
                if (o_.measureError) best = trial(v, h, t, coeffs, std::nullopt, prof);
                r.payloads = std::move(bestPayloads);
            }
        }
        if (r.payloads.empty()) codedBytes(h, coeffs, best, &r.payloads, prof);
        r.report.step = bestDelta;
        std::size_t corr = 0;
        for (const auto& c : best.corrections)
            corr += c.size();
        r.report.corrections = corr;
        r.report.maxError = best.err.maxErr;
        const double mse = best.err.sumSq / n;
        r.report.psnr = mse == 0 ? std::numeric_limits<double>::infinity() : 10 * std::log10(rangeSq / mse);
        return r;
    }

    // A fixed step whose error is not wanted (CodecOptions::step or a series frame reusing the first frame's
    // steps, with measureError off and no bound): each brick is quantised and coded straight from the mapped
    // batch, with no coefficient copy and no index array. `delta` sets the steps (else the header's are
    // kept). Returns nothing, having coded in vain, when a subband's magnitudes need a larger step than
    // `delta` gives (data of huge dynamic range; encodeLossy's setDelta raises such steps).
    std::optional<FrameResult> encodeDirect(const Volume& v, VczHeader& h, LiftingTransform<float>& t,
                                            std::optional<double> delta) {
        if (delta) h.steps = subbandSteps(h.wavelet, h.levels, *delta);
        FrameResult r;
        r.payloads.resize(h.brickCount());
        const std::size_t nsub = 1 + 7 * std::size_t(h.levels);
        std::vector<std::int32_t> brickMax(h.brickCount() * nsub, 0);
        forwardBricks<float>(cc_, t, v, h, o_.threads, &r.report.profile, r.report.transformMs, &r.ranges,
                             &CodecProfile::entropy, [&](std::size_t b, const float* c, std::size_t pitch) {
                                 const Dims d = h.brickDims(b);
                                 subbandMaxAbs(h, d, c, pitch, &brickMax[b * nsub]);
                                 thread_local std::vector<std::int32_t> q;
                                 q.resize(d.count());
                                 quantiseInto(h, d, c, pitch, q.data());
                                 r.payloads[b] = buildPayload(h, d, q, {});
                             });
        const std::vector<double> maxAbs = mergeMaxima(brickMax, nsub);
        for (std::size_t i = 0; i < nsub; ++i)
            if (h.steps[i] < maxAbs[i] / (kMaxQuantIndex - 2)) return std::nullopt;
        ++r.report.profile.trials;
        r.report.step = delta.value_or(0.0);
        r.report.maxError = r.report.psnr = std::numeric_limits<double>::quiet_NaN();
        return r;
    }

    // Per-subband maxima over all bricks from subbandMaxAbs's bit patterns (nsub per brick); refuses Inf and
    // NaN coefficients (finite voxels beyond the float transform's range): their bit patterns sort above
    // every finite magnitude's.
    static std::vector<double> mergeMaxima(const std::vector<std::int32_t>& brickMax, std::size_t nsub) {
        if (!brickMax.empty() && std::ranges::max(brickMax) >= 0x7f800000)
            throw DataError("voxel values too large for the float transform: use --lossless");
        std::vector<double> maxAbs(nsub, 0.0);
        for (std::size_t i = 0; i < brickMax.size(); ++i)
            maxAbs[i % nsub] = std::max(maxAbs[i % nsub], double(std::bit_cast<float>(brickMax[i])));
        return maxAbs;
    }

    // Bit pattern of the largest coefficient magnitude per subband of a dense brick (index as in h.steps),
    // merged into `out`. Bit patterns of magnitudes order like the magnitudes (Inf and NaN above all finite
    // ones), and an integer max reduction vectorises where a float one does not (NaN semantics).
    static void subbandMaxAbs(const VczHeader& h, Dims d, const float* c, std::size_t pitch,
                              std::int32_t* out) {
        for (const auto& sec : sectionLayout(d, h.levels))
            for (const SubbandBox& sb : sec) {
                const std::size_t si = subbandIndex(sb.level, sb.orient);
                std::int32_t m = 0;
                for (std::size_t z = sb.z0; z < sb.z1; ++z)
                    for (std::size_t y = sb.y0; y < sb.y1; ++y) {
                        const float* row = c + (z * d.y + y) * pitch;
                        std::int32_t rm = 0;
                        for (std::size_t x = sb.x0; x < sb.x1; ++x) {
                            const std::int32_t a = std::bit_cast<std::int32_t>(row[x]) & 0x7fffffff;
                            rm = a > rm ? a : rm;
                        }
                        m = std::max(m, rm);
                    }
                out[si] = std::max(out[si], m);
            }
    }

    ComputeContext& cc_;
    const CodecOptions& o_;
    const Volume* rangeOf_ = nullptr;
    ValueRange range_;
};

std::vector<std::byte> assemble(VczHeader& h, std::vector<FrameResult>& frames) {
    h.bricks.assign(frames.size(), std::vector<VczBrickEntry>(h.brickCount()));
    std::size_t offset = vczPreambleSize(h);
    std::vector<std::vector<std::uint8_t>> payloads;
    for (std::size_t f = 0; f < frames.size(); ++f) {
        for (std::size_t b = 0; b < h.brickCount(); ++b) {
            auto& p = frames[f].payloads[b];
            VczBrickEntry& e = h.bricks[f][b];
            e.offset = offset;
            e.size = p.size();
            e.checksum = vczChecksum(p);
            e.min = frames[f].ranges[b].first;
            e.max = frames[f].ranges[b].second;
            offset += p.size();
            payloads.push_back(std::move(p));
        }
    }
    return writeVcz(h, payloads);
}

} // namespace

std::vector<std::byte> encodeVolume(ComputeContext& cc, const Volume& volume, const CodecOptions& options,
                                    EncodeReport* report) {
    Stopwatch total;
    Encoder enc(cc, options);
    VczHeader h = enc.plan(volume);
    std::vector<FrameResult> frames;
    frames.push_back(enc.encodeFrame(volume, h, true));
    if (h.transform == TransformKind::IntegerLifting) {
        // The bricks' ranges (measured by the forward pass) give the volume's: no scan of the voxels.
        h.valueMin = std::numeric_limits<double>::infinity();
        h.valueMax = -h.valueMin;
        for (const auto& [lo, hi] : frames[0].ranges) {
            h.valueMin = std::min(h.valueMin, lo);
            h.valueMax = std::max(h.valueMax, hi);
        }
    } else {
        const ValueRange st = enc.rangeOf(volume);
        h.valueMin = st.min;
        h.valueMax = st.max;
    }
    std::vector<std::byte> bytes;
    timeStage(&frames[0].report.profile, &CodecProfile::assemble, [&] { bytes = assemble(h, frames); });
    frames[0].report.profile.total = total.milliseconds();
    if (report) {
        *report = frames[0].report;
        report->bytes = bytes.size();
        report->bitsPerVoxel = double(bytes.size()) * 8 / double(volume.voxelCount());
    }
    return bytes;
}

std::vector<std::byte> encodeSeries(ComputeContext& cc, const TimeSeries& series,
                                    const CodecOptions& options) {
    series.validate();
    if (series.frames.empty()) throw UsageError("cannot encode an empty time series");
    Encoder enc(cc, options);
    VczHeader h = enc.plan(series.frames[0]);
    h.frames.resize(series.frames.size());
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    std::vector<FrameResult> frames;
    for (std::size_t f = 0; f < series.frames.size(); ++f) {
        const VolumeStats st = series.frames[f].stats(1);
        lo = std::min(lo, st.min);
        hi = std::max(hi, st.max);
        if (f < series.times.size()) h.frames[f].time = series.times[f];
        // Rate searches run on the first frame; later frames reuse its steps (one header for the series).
        frames.push_back(enc.encodeFrame(series.frames[f], h, f == 0));
    }
    h.valueMin = lo;
    h.valueMax = hi;
    return assemble(h, frames);
}

Region parseRegion(std::string_view text) {
    Region r;
    std::size_t v[6];
    const std::string s(text);
    char c1, c2, c3, c4, c5;
    int consumed = 0;
    if (std::sscanf(s.c_str(), "%zu %c %zu %c %zu %c %zu %c %zu %c %zu%n", &v[0], &c1, &v[1], &c2, &v[2], &c3,
                    &v[3], &c4, &v[4], &c5, &v[5], &consumed) != 11 ||
        c1 != ',' || c2 != ',' || c3 != ':' || c4 != ',' || c5 != ',' ||
        static_cast<std::size_t>(consumed) != s.size())
        throw UsageError("--region must look like x0,y0,z0:x1,y1,z1 (got '" + s + "')");
    r.lo = {v[0], v[1], v[2]};
    r.hi = {v[3], v[4], v[5]};
    if (r.lo.x >= r.hi.x || r.lo.y >= r.hi.y || r.lo.z >= r.hi.z)
        throw UsageError("--region " + s + " is empty: each upper bound must exceed its lower bound");
    return r;
}

// ------------------------------------------------------------------------------ decoder

VczReader::VczReader(std::vector<std::byte> bytes, std::string name)
    : bytes_(std::move(bytes)), name_(std::move(name)) {
    header_ = readVczHeader(bytes_, name_);
}

namespace {

// Brick b's exactly stored voxels (--max-error outliers) that fall into [a, e), at full resolution.
template <class V>
void applyCorrections(const VczHeader& h, std::size_t b, Dims a, Dims e, std::span<V> out, Dims outDims,
                      const std::vector<Correction>& corrections) {
    const Dims o = h.brickOrigin(b), d = h.brickDims(b);
    for (const Correction& c : corrections) {
        const std::size_t x = o.x + c.index % d.x, y = o.y + c.index / d.x % d.y,
                          z = o.z + c.index / (d.x * d.y);
        if (x >= a.x && x < e.x && y >= a.y && y < e.y && z >= a.z && z < e.z)
            out[((z - a.z) * outDims.y + (y - a.y)) * outDims.x + (x - a.x)] = static_cast<V>(c.value);
    }
}

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
                            o1[i] = static_cast<V>(std::clamp<std::int32_t>(in[i], std::numeric_limits<V>::min(),
                                                                           std::numeric_limits<V>::max()));
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

// Entropy decodes the listed bricks of one frame on host threads, inverts them on the device down to
// `level` and places each brick's part of [a, e) into `out` (zero on entry) straight from the mapped batch.
template <class V>
void decodeBricksInto(ComputeContext& cc, std::span<const std::byte> file, const VczHeader& h,
                      std::size_t frame, const std::vector<std::size_t>& which, int level, unsigned threads,
                      const std::string& name, CodecProfile* prof, Dims a, Dims e, std::span<V> out,
                      Dims outDims, bool placeOnDevice) {
    if (frame >= h.frames.size()) throw UsageError(name + ": no frame " + std::to_string(frame));
    if (h.frames[frame].type != FrameType::I)
        throw DataError(name + ": frame " + std::to_string(frame) +
                        " is a motion-compensated frame; this decoder reads I frames");
    const std::size_t n = h.brickCount();
    const int levels = h.transform == TransformKind::RawBits ? 0 : h.levels;
    const int stop = h.transform == TransformKind::RawBits ? 0 : level;
    std::vector<std::vector<std::int32_t>> ints(n);
    std::vector<std::vector<Correction>> corrections(n);
    const Dequantiser dq{h.steps, h.reconstructionBias};
    // Entropy decodes brick b into rows of `pitch` elements (a batch slot, or a dense array); lossy bricks
    // come out dequantised (float bit patterns).
    auto entropyDecode = [&](std::size_t b, std::int32_t* dst, std::size_t pitch) {
        const std::string what = name + ": brick " + std::to_string(b);
        const auto payload = vczBrickPayload(file, h, frame, b, name);
        const Dims d = h.brickDims(b), storage{pitch, d.y, d.z};
        const auto layout = sectionLayout(d, levels);
        const ParsedPayload p = parsePayload(payload, layout.size(), what);
        const std::span<std::int32_t> c(dst, storage.count());
        // Sections finer than the level are not decoded; the inverse never reads them, but keep them defined.
        if (stop > 0) std::fill(c.begin(), c.end(), 0);
        decodeSections(std::span(p.sections).first(layout.size() - std::size_t(stop)), c, storage, layout,
                       h.entropy, what.c_str(), h.transform == TransformKind::FloatLifting ? &dq : nullptr);
        if (!p.corrections.empty() && level == 0)
            corrections[b] = decodeCorrections(p.corrections, h.type, d.count(), what);
    };
    auto place = [&](std::size_t b, const auto* src, std::size_t pitch) {
        placeBrick(h, b, level, a, e, out, outDims, src, pitch, corrections[b]);
    };
    // Uniform bricks are filled with their value, not decoded: each filter's low band of a constant is that
    // constant, so this is exact at every level. Their payload checksums are still verified. `out` starts
    // zeroed (a new Volume, whose large blocks are untouched zero pages), so zero bricks are not written at
    // all. Before the output is handed to the device below.
    std::vector<std::size_t> varying;
    std::vector<std::pair<std::size_t, V>> uniform;
    for (std::size_t b : which) {
        if (const std::optional<V> v = uniformValue<V>(h, h.bricks[frame][b]))
            uniform.emplace_back(b, *v);
        else
            varying.push_back(b);
    }
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
    bool placedOnDevice = false;
    if (varying.empty()) {
        // Every brick was uniform.
    } else if (h.transform == TransformKind::IntegerLifting) {
        // Decoded straight into the batch.
        LiftingTransform<std::int32_t> t(cc, h.wavelet);
        placedOnDevice =
            inverseBricks(cc, t, h, varying, level, threads, prof, {{&CodecProfile::entropy, entropyDecode}},
                          &CodecProfile::assemble, place, toVoxels ? &*toVoxels : nullptr);
    } else if (h.transform == TransformKind::FloatLifting) {
        // Quantisation indices are decoded into the batch slot as int32 and dequantised there in place (the
        // entropy stage includes it): no separate index array.
        LiftingTransform<float> t(cc, h.wavelet);
        placedOnDevice = inverseBricks(cc, t, h, varying, level, threads, prof,
                                       {{&CodecProfile::entropy,
                                         [&](std::size_t b, float* dst, std::size_t pitch) {
                                             entropyDecode(b, reinterpret_cast<std::int32_t*>(dst), pitch);
                                         }}},
                                       &CodecProfile::assemble, place, toVoxels ? &*toVoxels : nullptr);
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
    if (placedOnDevice)
        timeStage(prof, &CodecProfile::assemble, [&] {
            // Mapping makes the kernel's writes visible in `out` (no copy where the device works in it).
            BatchMapping<V> m(cc.queue(), toVoxels->voxels, out.size(), CL_MAP_READ | CL_MAP_WRITE);
            for (std::size_t b : which)
                applyCorrections(h, b, a, e, std::span<V>(m.data(), out.size()), outDims, corrections[b]);
        });
}

} // namespace

Volume VczReader::decode(ComputeContext& cc, const DecodeOptions& o) const {
    const VczHeader& h = header_;
    const int maxLevel = h.transform == TransformKind::RawBits ? 16 : h.levels;
    if (o.level < 0 || o.level > maxLevel)
        throw UsageError(name_ + ": --level must be between 0 and " + std::to_string(maxLevel) +
                         " (the encoded levels)");
    Region r{{0, 0, 0}, h.dims};
    if (o.region) {
        r = *o.region;
        if (r.hi.x > h.dims.x || r.hi.y > h.dims.y || r.hi.z > h.dims.z || r.lo.x >= r.hi.x ||
            r.lo.y >= r.hi.y || r.lo.z >= r.hi.z)
            throw UsageError(name_ + ": --region lies outside the volume (" + std::to_string(h.dims.x) + "x" +
                             std::to_string(h.dims.y) + "x" + std::to_string(h.dims.z) + ")");
    }
    const std::size_t f = std::size_t(1) << o.level;
    auto up = [f](std::size_t v) { return (v + f - 1) / f; };
    const Dims a{up(r.lo.x), up(r.lo.y), up(r.lo.z)}, e{up(r.hi.x), up(r.hi.y), up(r.hi.z)};
    const Dims outDims{e.x - a.x, e.y - a.y, e.z - a.z};
    if (outDims.count() == 0)
        throw UsageError(name_ + ": the region holds no sample at level " + std::to_string(o.level));
    std::vector<std::size_t> which;
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        const Dims bo = h.brickOrigin(b), bd = h.brickDims(b);
        if (bo.x < r.hi.x && bo.x + bd.x > r.lo.x && bo.y < r.hi.y && bo.y + bd.y > r.lo.y && bo.z < r.hi.z &&
            bo.z + bd.z > r.lo.z)
            which.push_back(b);
    }
    Stopwatch total;
    Volume out(outDims, h.type);
    for (int i = 0; i < 3; ++i) {
        const std::size_t first = i == 0 ? a.x : i == 1 ? a.y : a.z;
        out.spacing[i] = h.spacing[i] * double(f);
        out.origin[i] = h.origin[i] + double(first * f) * h.spacing[i];
    }
    // Bricks cover disjoint parts of the output, so they are placed in parallel.
    visitTyped(out, [&](auto span) {
        decodeBricksInto(cc, bytes_, h, o.frame, which, o.level, o.threads, name_, o.profile, a, e, span,
                         outDims, o.placeOnDevice);
    });
    if (o.profile) o.profile->total += total.milliseconds();
    return out;
}

Volume VczReader::decodeBrick(ComputeContext& cc, std::size_t frame, std::size_t brick, int level) const {
    if (brick >= header_.brickCount()) throw UsageError(name_ + ": no brick " + std::to_string(brick));
    const Dims o = header_.brickOrigin(brick), d = header_.brickDims(brick);
    DecodeOptions opt;
    opt.region = Region{o, {o.x + d.x, o.y + d.y, o.z + d.z}};
    opt.level = level;
    opt.frame = frame;
    opt.threads = 1;
    return decode(cc, opt);
}

Volume decodeVolume(ComputeContext& cc, std::span<const std::byte> vcz, const DecodeOptions& options,
                    const std::string& name) {
    VczReader r(std::vector<std::byte>(vcz.begin(), vcz.end()), name);
    return r.decode(cc, options);
}

// ------------------------------------------------------------------------------ metrics

namespace {
template <class Fn> void forEachPair(const Volume& a, const Volume& b, Fn fn) {
    if (a.dims() != b.dims()) throw UsageError("volumes differ in dimensions: cannot compare");
    for (std::size_t i = 0; i < a.voxelCount(); ++i)
        fn(a.valueAt(i), b.valueAt(i));
}
} // namespace

double maxAbsError(const Volume& a, const Volume& b) {
    double m = 0;
    forEachPair(a, b, [&](double x, double y) { m = std::max(m, std::abs(x - y)); });
    return m;
}

double rmse(const Volume& a, const Volume& b) {
    double s = 0;
    forEachPair(a, b, [&](double x, double y) { s += (x - y) * (x - y); });
    return std::sqrt(s / double(a.voxelCount()));
}

double psnr(const Volume& a, const Volume& b) {
    const double e = rmse(a, b);
    const VolumeStats st = a.stats(1);
    if (e == 0) return std::numeric_limits<double>::infinity();
    if (st.max == st.min) return std::numeric_limits<double>::quiet_NaN();
    return 20 * std::log10((st.max - st.min) / e);
}

} // namespace volcl
