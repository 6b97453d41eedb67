// 3D separable lifting wavelet transforms: OpenCL passes over batches of bricks and plain C++ references.
#pragma once

#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "wavelet/CodecTypes.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>
#include <string_view>
#include <utility>
#include <vector>

namespace volcl {

/// Size of the low-pass corner after `level` levels: ceil(n / 2^level) per axis.
Dims levelDims(Dims d, int level) noexcept;

/// Plain C++ references (sequential in-place lifting on the interleaved signal, the textbook form),
/// used by tests to check the kernels. Outputs use the Mallat layout: ceil(n/2) low then floor(n/2) high.
namespace reference {
void forward1d(std::span<std::int32_t> line, Wavelet w); ///< reversible integer form; Cdf97 throws
void inverse1d(std::span<std::int32_t> line, Wavelet w);
void forward1d(std::span<double> line, Wavelet w); ///< linear float form
void inverse1d(std::span<double> line, Wavelet w);
/// `levels` levels of x, y, z passes on the shrinking low corner of a brick stored x fastest.
void forward3d(std::span<std::int32_t> data, Dims dims, int levels, Wavelet w);
void forward3d(std::span<double> data, Dims dims, int levels, Wavelet w);
/// Undoes levels levels-1 .. stopLevel; with stopLevel k the low corner levelDims(dims, k) holds the
/// level-k approximation.
void inverse3d(std::span<std::int32_t> data, Dims dims, int levels, Wavelet w, int stopLevel = 0);
void inverse3d(std::span<double> data, Dims dims, int levels, Wavelet w, int stopLevel = 0);
} // namespace reference

/// Host view of a device buffer, mapped until destroyed or unmap() (zero-copy on CPU devices, where the
/// buffer is allocated in host memory). Kernels must not use the buffer while it is mapped.
template <class T> class BatchMapping {
public:
    BatchMapping() = default;
    BatchMapping(cl::CommandQueue& queue, cl::Buffer& buffer, std::size_t count, cl_map_flags flags);
    ~BatchMapping() { unmap(); }
    BatchMapping(const BatchMapping&) = delete;
    BatchMapping& operator=(const BatchMapping&) = delete;
    BatchMapping(BatchMapping&& o) noexcept { *this = std::move(o); }
    BatchMapping& operator=(BatchMapping&& o) noexcept;
    std::span<T> span() const noexcept { return {ptr_, count_}; }
    T* data() const noexcept { return ptr_; }
    void unmap() noexcept;

private:
    cl::CommandQueue* queue_ = nullptr;
    cl::Buffer* buffer_ = nullptr;
    T* ptr_ = nullptr;
    std::size_t count_ = 0;
};

/// `count` bricks of the same dims on the device, stacked along z with the row pitch rounded up to 16
/// (the x pass works on 16-wide vectors). The streaming passes ping-pong between two buffers (the second
/// allocated on first use); `data()` is the current.
/// T is std::int32_t (reversible path) or float (lossy path).
template <class T> class BrickBatch {
public:
    BrickBatch(ComputeContext& cc, Dims brick, std::size_t count);
    /// A batch over `filled`, a block of cc's host pool of at least bytesFor(brick, count) bytes that the
    /// caller already wrote in the padded layout (before cc's device existed, say).
    BrickBatch(ComputeContext& cc, Dims brick, std::size_t count, HostBlock filled);
    /// Bytes of a batch's buffer: `count` bricks in the padded layout plus the kernels' read slack.
    static std::size_t bytesFor(Dims brick, std::size_t count) noexcept {
        return (strideFor(brick) * count + kSlack) * sizeof(T);
    }
    /// pitch() of a batch of bricks `x` elements wide.
    static std::size_t pitchFor(std::size_t x) noexcept { return roundUp(std::max<std::size_t>(x, 1), 16); }
    Dims brick() const noexcept { return brick_; }
    std::size_t count() const noexcept { return count_; }
    std::size_t pitch() const noexcept { return pitch_; }
    /// Elements per brick in the padded layout (pitch * by * bz).
    std::size_t brickStride() const noexcept { return pitch_ * brick_.y * brick_.z; }
    /// brickStride() of a batch of `brick`-shaped bricks, without making one.
    static std::size_t strideFor(Dims brick) noexcept { return pitchFor(brick.x) * brick.y * brick.z; }
    /// Host array in the padded layout, brick after brick, ready for upload()/filled by download().
    std::vector<T> makeHost() const { return std::vector<T>(brickStride() * count_); }
    void upload(ComputeContext& cc, std::span<const T> host);
    void download(ComputeContext& cc, std::span<T> host);
    /// Maps the input buffer for writing bricks in place (no host copy); forward()/inverse() start from it.
    /// `keepContents` keeps what the buffer holds (a batch over prefilled memory), else it is undefined.
    BatchMapping<T> mapForWrite(ComputeContext& cc, bool keepContents = false);
    /// Maps the current buffer (the transform's result) for reading.
    BatchMapping<T> mapForRead(ComputeContext& cc);
    DeviceBuffer<T>& data() noexcept { return current_ ? b_ : a_; }
    /// The streaming passes' second buffer, allocated on first use: the brick-resident kernel (CPUs) works
    /// in place and never needs it.
    DeviceBuffer<T>& scratch(ComputeContext& cc);
    void swap() noexcept { current_ = !current_; }

private:
    // Elements past the last brick: the brick kernel's x pass reads and blends whole 16-lane vectors that may
    // run up to 16 elements past the last row.
    static constexpr std::size_t kSlack = 32;
    Dims brick_;
    std::size_t count_ = 0, pitch_ = 0;
    DeviceBuffer<T> a_, b_;
    bool current_ = false;
};

/// Which kernels run a transform. Streaming: one launch per pass over the whole batch (lifting.cl), any
/// device and brick size. BrickResident: one work-item per brick runs every pass of every level in place
/// (lifting_brick.cl), so the brick stays in a CPU core's cache. Auto picks BrickResident on CPU devices
/// for bricks up to kBrickResidentMaxDim per axis, Streaming otherwise.
enum class LiftingPath : std::uint8_t { Auto, Streaming, BrickResident };

/// A volume whose voxels a transform reads (LiftingTransform::forwardFromVoxels) or writes
/// (inverseToVoxels): `type` and `dims`, the voxels in `voxels`; brick i of batch k has its first voxel at
/// `origins[k][i]`. Bricks must lie inside the volume (and not overlap, when written).
struct VoxelVolume {
    cl::Buffer voxels;
    ScalarType type = ScalarType::Float32;
    Dims dims;
    std::vector<std::vector<Dims>> origins;
};

/// Runs the lifting passes of one wavelet on the device. Build once, reuse for many batches.
/// Example:
/// ```
/// volcl::LiftingTransform<std::int32_t> t(cc, volcl::Wavelet::Cdf53);
/// volcl::BrickBatch<std::int32_t> batch(cc, {64, 64, 64}, 8);
/// batch.upload(cc, host);
/// t.forward(cc, batch, 3);
/// batch.download(cc, host);   // Mallat-ordered coefficients per brick
/// ```
template <class T> class LiftingTransform {
public:
    /// Throws UsageError for an integer transform of a wavelet without an integer form.
    LiftingTransform(ComputeContext& cc, Wavelet w);
    Wavelet wavelet() const noexcept { return wavelet_; }
    /// Forces a kernel path (tests compare both); the default Auto chooses per batch.
    void setPath(LiftingPath p) noexcept { path_ = p; }
    /// The path forward()/inverse() take for this batch.
    LiftingPath pathFor(const BrickBatch<T>& batch) const noexcept { return pathFor(batch.brick()); }
    /// The path for batches of bricks of these dims.
    LiftingPath pathFor(Dims brick) const noexcept;
    /// Largest brick dimension the brick-resident kernel takes (its private line buffers are sized by it).
    static constexpr std::size_t kBrickResidentMaxDim = 256;
    /// Forward transform with `levels` levels. Returns the summed kernel time in milliseconds.
    double forward(ComputeContext& cc, BrickBatch<T>& batch, int levels);
    /// Inverse from level levels-1 down to stopLevel. Returns the summed kernel time in milliseconds.
    double inverse(ComputeContext& cc, BrickBatch<T>& batch, int levels, int stopLevel = 0);
    /// Batches the brick-resident kernel transforms in one launch: a volume's bricks come in at most 8
    /// shapes (an interior and an edge size per axis).
    static constexpr std::size_t kMaxShapes = 8;
    /// forward() of several batches (e.g. one per brick shape of a volume): those on the brick-resident
    /// path in one launch (per kMaxShapes batches), so the cores stay busy across shapes. Returns the summed
    /// kernel time in milliseconds.
    double forward(ComputeContext& cc, std::span<BrickBatch<T>* const> batches, int levels);
    /// inverse() of several batches, as forward() above.
    double inverse(ComputeContext& cc, std::span<BrickBatch<T>* const> batches, int levels,
                   int stopLevel = 0);

    /// True when forwardFromVoxels() and inverseToVoxels() take these batches (every one on the
    /// brick-resident path).
    bool canUseVoxels(std::span<BrickBatch<T>* const> batches) const noexcept;
    /// inverse() down to level 0 that also converts each brick to voxels and writes it into `target` from
    /// inside the kernel, right after its last level while it is in the core's cache, so nobody reads the
    /// batch back: integers are clamped to the voxel type, floats rounded to nearest even and clamped (what
    /// the decoder's host placement does). The batches keep the reconstruction too. Throws Error unless
    /// canUseVoxels(batches). Returns the summed kernel time in milliseconds. Example:
    /// ```
    /// volcl::VoxelVolume v{cc.wrapHost(out.values<std::uint8_t>()).get(), volcl::ScalarType::UInt8,
    ///                      out.dims(), {{{0, 0, 0}, {64, 0, 0}}}};
    /// t.inverseToVoxels(cc, batches, 4, v);
    /// ```
    double inverseToVoxels(ComputeContext& cc, std::span<BrickBatch<T>* const> batches, int levels,
                           const VoxelVolume& target);
    /// forward() that first reads each brick's voxels from `source` inside the kernel (converting them to T)
    /// instead of from a batch the host filled, so the brick is in the core's cache when its first level
    /// starts; the batches' contents before the call do not matter. With `ranges`, (*ranges)[k][i] receives
    /// the smallest and largest voxel of brick i of batch k. Integer transforms take integer voxels only.
    /// Throws Error unless canUseVoxels(batches). Returns the summed kernel time in milliseconds.
    double forwardFromVoxels(ComputeContext& cc, std::span<BrickBatch<T>* const> batches, int levels,
                             const VoxelVolume& source,
                             std::vector<std::vector<std::pair<double, double>>>* ranges = nullptr);

private:
    double pass(ComputeContext& cc, cl::Kernel& k, BrickBatch<T>& batch, Dims active, int axis);
    double copyBack(ComputeContext& cc, BrickBatch<T>& batch, Dims active);
    // `voxels`: the inverse (to level 0 only) also writes voxels there, the forward reads them from there
    // and stores each brick's range in `ranges`; `first` = the index of batches[0] in them.
    double brickResident(ComputeContext& cc, std::span<BrickBatch<T>* const> batches, bool inverse,
                         int levels, int stopLevel, const VoxelVolume* voxels = nullptr,
                         std::size_t first = 0,
                         std::vector<std::vector<std::pair<double, double>>>* ranges = nullptr);
    void checkVoxels(std::span<BrickBatch<T>* const> batches, int levels, const VoxelVolume& v) const;
    // forwardFromVoxels() / inverseToVoxels(): the brick kernel per kMaxShapes batches.
    double withVoxels(ComputeContext& cc, std::span<BrickBatch<T>* const> batches, bool inverse, int levels,
                      const VoxelVolume& v, std::vector<std::vector<std::pair<double, double>>>* ranges);
    double transformAll(ComputeContext& cc, std::span<BrickBatch<T>* const> batches, bool inverse, int levels,
                        int stopLevel);
    void buildStreaming(ComputeContext& cc); // the lifting.cl kernels, once
    void useBrickSize(std::size_t maxN); // the lifting_brick.cl kernels from now on are for LIFT_MAXN maxN
    cl::Kernel& brickKernel(ComputeContext& cc, bool inverse); // built on first use
    KernelDefines brickDefines(bool inverse) const;            // lifting_brick.cl's -D for this transform
    cl::Kernel& voxelKernel(ComputeContext& cc, ScalarType type,
                            bool inverse); // reading/writing `type` voxels
    Wavelet wavelet_;
    LiftingPath path_ = LiftingPath::Auto;
    bool brickResidentDevice_ = false; // the device profile allows LiftingPath::BrickResident
    bool streamingBuilt_ = false;
    cl::Kernel fwdX_, fwdYz_, invX_, invYz_, copy_;
    std::size_t brickMaxN_ = 0; // LIFT_MAXN of the brick kernels below (0: none chosen yet)
    cl::Kernel fwdBrick_, invBrick_;
    std::array<cl::Kernel, 8> brickVoxels_; // [inverse * 4 + ScalarType], built on first use for brickMaxN_
    DeviceBuffer<cl_int> brickNext_;        // the brick kernel's work counter
};

} // namespace volcl
