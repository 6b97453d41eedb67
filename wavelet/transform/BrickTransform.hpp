// The transform stage: device orchestration of the lifting kernels over batches of equally shaped bricks,
// with host fill steps writing each brick into its batch slot and emit steps reading it back from the mapped
// batch (or the inverse kernel writing voxels itself).
#pragma once

#include "core/runtime/ParallelFor.hpp"
#include "wavelet/BrickVoxels.hpp"
#include "wavelet/StageTiming.hpp"
#include "wavelet/container/VczFormat.hpp"
#include "wavelet/quantise/Corrections.hpp"
#include "wavelet/transform/LiftingTransform.hpp"

#include <algorithm>
#include <functional>
#include <memory>
#include <numeric>
#include <span>
#include <vector>

namespace volcl::codec {

// Bricks of equal dims are transformed together in one batch.
struct BrickGroup {
    Dims dims;
    std::vector<std::size_t> bricks;
};
std::vector<BrickGroup> groupBricks(const VczHeader& h, const std::vector<std::size_t>& which);

// One step that writes a brick into its batch slot: fn(b, dst, pitch) with rows of `pitch` elements,
// timed as `stage`.
template <class T> struct FillStep {
    double CodecProfile::*stage;
    std::function<void(std::size_t, T*, std::size_t)> fn;
};

// Batch memory of one transform round. A one-shot process (a `volcl encode` or `decode` of one file) pays for
// every fresh page it touches, at 0.3-1.5 GB/s on a virtual machine; batches for all of a 35 MB volume's bricks
// at once (140 MB of int32) cost more than its transform. Rounds of this size (8 bricks of 64^3 int32) reuse
// the same pooled blocks and still give each launch a few bricks (one work-item each) per core. A one-shot
// decode of that volume was 1.58x its warm time with 24 MB rounds and 1.46x with 8 MB; warm times unchanged.
inline constexpr std::size_t kTransformRoundBytes = std::size_t(8) << 20;

// The groups cut into rounds of at most `budget` bytes of batch memory (`strideBytes(dims)` per brick): pieces
// of groups packed in order, a group split where it does not fit, a brick larger than the budget alone.
std::vector<std::vector<BrickGroup>> transformRounds(const std::vector<BrickGroup>& groups,
                                                     std::size_t (*strideBytes)(Dims), std::size_t budget);

// The rounds transformBricks cuts the listed bricks into, for batches of T: groups of equal shape, at most
// kTransformRoundBytes of batch memory each. Slot k of a round is the k-th brick counting its groups in order.
template <class T>
std::vector<std::vector<BrickGroup>> batchRounds(const VczHeader& h, const std::vector<std::size_t>& which) {
    const auto strideBytes = [](Dims d) { return BrickBatch<T>::strideFor(d) * sizeof(T); };
    return transformRounds(groupBricks(h, which), strideBytes, kTransformRoundBytes);
}

// Zeroes the row padding of a brick written into a batch slot (rows of `pitch` elements, brick `d`). The
// kernels' full-width vector steps compute on the padding too, and pooled memory may hold old integers there,
// which read as floats are denormals (an assist per vector instruction on x86). A precaution: no speed
// difference was measurable under load. (The slack after the last brick is left alone: only the last row's
// vector reads reach it, and zeroing it cost two fill commands per batch.)
template <class T> void zeroRowPadding(T* slot, Dims d, std::size_t pitch) {
    if (pitch > d.x)
        for (std::size_t r = 0; r < d.y * d.z; ++r)
            std::fill(slot + r * pitch + d.x, slot + (r + 1) * pitch, T(0));
}

// Batch memory of one round of batchRounds, written on host threads before transformBricks runs (while the
// device started, see DecodeAhead): a block of the context's host pool per group, of BrickBatch<T>::bytesFor
// the group, and which slots already hold their brick (the fill steps write the others).
struct PrefilledRound {
    std::vector<HostBlock> blocks;
    std::vector<char> filled;
};

// What a DecodeAhead hands the decoder: the first rounds' batch memory (see PrefilledRound) and the exactly
// stored voxels of each brick it decoded (indexed by brick; empty for the others).
struct AheadHandover {
    std::vector<PrefilledRound> rounds;
    std::vector<std::vector<Correction>> corrections;
};

// Runs one transform over the listed bricks, batched by brick shape, in rounds of at most
// kTransformRoundBytes of batch memory. In each round the fill steps write each brick into its batch slot;
// run(batches, groups) transforms the round (one launch on CPUs) and returns true when it also delivered the
// result (as voxels, see VoxelPlacement); otherwise emit(b, src, pitch) reads it from the mapped batch (timed
// as `emitStage`), so no dense copy is made. The result is true when every round's run returned true. Filling
// and emitting are each one parallel loop over all bricks of the round's batches (per-shape loops left a
// thread idle on shapes with a single brick), and a brick's fill steps run back to back, so later steps find
// the brick in cache. `prefilled`, when given, holds the first rounds' memory with some or all of their bricks
// already written (the fill steps skip those).
template <class T, class Run, class Emit>
bool transformBricks(ComputeContext& cc, const VczHeader& h, const std::vector<std::size_t>& which,
                     unsigned threads, CodecProfile* prof, const std::vector<FillStep<T>>& fills, Run run,
                     double CodecProfile::*emitStage, Emit emit,
                     std::vector<PrefilledRound>* prefilled = nullptr) {
    bool allEmitted = true;
    const std::vector<std::vector<BrickGroup>> rounds = batchRounds<T>(h, which);
    for (std::size_t round = 0; round < rounds.size(); ++round) {
        const std::vector<BrickGroup>& groups = rounds[round];
        PrefilledRound* pre = prefilled && round < prefilled->size() ? &(*prefilled)[round] : nullptr;
        if (pre && (pre->blocks.size() != groups.size()))
            throw Error("internal: prefilled round does not match");
        std::vector<std::unique_ptr<BrickBatch<T>>> batches;
        struct Slot {
            std::size_t brick, group, index;
        };
        std::vector<Slot> slots;
        for (std::size_t g = 0; g < groups.size(); ++g) {
            const std::size_t n = groups[g].bricks.size();
            batches.push_back(
                pre ? std::make_unique<BrickBatch<T>>(cc, groups[g].dims, n, std::move(pre->blocks[g]))
                    : std::make_unique<BrickBatch<T>>(cc, groups[g].dims, n));
            for (std::size_t i = 0; i < n; ++i)
                slots.push_back({groups[g].bricks[i], g, i});
        }
        if (pre && pre->filled.size() != slots.size())
            throw Error("internal: prefilled round does not match");
        auto prefilledSlot = [&](std::size_t k) { return pre && pre->filled[k]; };
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
                    maps[g] = batches[g]->mapForWrite(cc, pre != nullptr);
            });
            // Each fill stage gets the loop's wall time in proportion to its summed per-brick time.
            std::vector<double> stepMs(fills.size() * slots.size(), 0.0);
            Stopwatch wall;
            parallelFor(slots.size(), threads, [&](std::size_t k) {
                if (prefilledSlot(k)) return;
                const Slot& s = slots[k];
                T* dst = maps[s.group].data() + s.index * batches[s.group]->brickStride();
                for (std::size_t f = 0; f < fills.size(); ++f) {
                    Stopwatch sw;
                    fills[f].fn(s.brick, dst, batches[s.group]->pitch());
                    if (prof) stepMs[f * slots.size() + k] = sw.milliseconds();
                }
                zeroRowPadding(dst, groups[s.group].dims, batches[s.group]->pitch());
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
        if (emitted) continue;
        allEmitted = false;
        timeStage(prof, &CodecProfile::download, [&] {
            for (std::size_t g = 0; g < groups.size(); ++g)
                maps[g] = batches[g]->mapForRead(cc);
        });
        forEachSlot(emitStage, [&](std::size_t b, T* src, std::size_t pitch) {
            emit(b, static_cast<const T*>(src), pitch);
        });
    }
    return !which.empty() && allEmitted;
}

/// 0, 1, ..., brickCount() - 1.
std::vector<std::size_t> allBricks(const VczHeader& h);

// Each brick's first voxel relative to `first`, per batch group (VoxelVolume::origins).
std::vector<std::vector<Dims>> brickOrigins(const VczHeader& h, const std::vector<BrickGroup>& groups,
                                            Dims first);

// Forward transform of every brick: emit(b, coefficients, pitch) sees each brick's coefficients in the mapped
// batch. Adds kernel time to `ms` and, with `ranges`, stores each brick's voxel min and max (gathered on the
// way).
template <class T, class Emit>
void forwardBricks(ComputeContext& cc, LiftingTransform<T>& t, const Volume& v, const VczHeader& h,
                   unsigned threads, CodecProfile* prof, double& ms,
                   std::vector<std::pair<double, double>>* ranges, double CodecProfile::*emitStage,
                   Emit emit) {
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
                   const VoxelPlacement* toVoxels = nullptr,
                   std::vector<PrefilledRound>* prefilled = nullptr) {
    // Decided for the whole call, not per round: either every round writes voxels or every brick is emitted.
    const std::vector<BrickGroup> shapes = groupBricks(h, which);
    const bool voxels =
        toVoxels && level == 0 && std::all_of(shapes.begin(), shapes.end(), [&](const BrickGroup& g) {
            return t.pathFor(g.dims) == LiftingPath::BrickResident;
        });
    return transformBricks<T>(
        cc, h, which, threads, prof, fills,
        [&](std::span<BrickBatch<T>* const> b, const std::vector<BrickGroup>& groups) {
            if (voxels) {
                t.inverseToVoxels(cc, b, h.levels,
                                  {toVoxels->voxels, toVoxels->type, toVoxels->dims,
                                   brickOrigins(h, groups, toVoxels->first)});
                return true;
            }
            t.inverse(cc, b, h.levels, level);
            return false;
        },
        emitStage, emit, prefilled);
}

} // namespace volcl::codec
