// Lifting transforms: C++ references (textbook in-place lifting) and the OpenCL pass driver.
#include "wavelet/transform/LiftingTransform.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cstdlib>
#include <numeric>
#include <string>
#include <type_traits>

namespace volcl {

std::string_view waveletName(Wavelet w) noexcept {
    switch (w) {
    case Wavelet::Cdf53:
        return "cdf53";
    case Wavelet::Cdf97:
        return "cdf97";
    case Wavelet::Haar:
        return "haar";
    case Wavelet::Cdf26:
        return "cdf26";
    }
    return "unknown";
}

Wavelet parseWavelet(std::string_view name) {
    for (Wavelet w : {Wavelet::Cdf53, Wavelet::Cdf97, Wavelet::Haar, Wavelet::Cdf26})
        if (name == waveletName(w)) return w;
    throw UsageError("unknown wavelet '" + std::string(name) + "' (use cdf53, cdf97, haar or cdf26)");
}

bool hasIntegerForm(Wavelet w) noexcept {
    return w != Wavelet::Cdf97;
}

Dims levelDims(Dims d, int level) noexcept {
    auto shrink = [level](std::size_t n) { return level <= 0 ? n : ((n - 1) >> level) + 1; };
    return {shrink(d.x), shrink(d.y), shrink(d.z)};
}

namespace {

// CDF 9/7 lifting constants in double (the kernels use the same values rounded to float).
constexpr double kA = -1.586134342059924, kB = -0.052980118572961, kG = 0.882911075530934,
                 kD = 0.443506852043971, kK = 1.230174104914001;

// Rounding of the integer forms (floor via arithmetic shift) and the linear float forms.
inline std::int32_t half(std::int32_t a) {
    return a >> 1;
}
inline std::int32_t quarterR(std::int32_t a) {
    return (a + 2) >> 2;
}
inline double half(double a) {
    return a * 0.5;
}
inline double quarterR(double a) {
    return a * 0.25;
}

int mirror(int i, int n) {
    const int p = 2 * (n - 1);
    i %= p;
    if (i < 0) i += p;
    return i < n ? i : p - i;
}

template <class T> void deinterleave(const std::vector<T>& t, std::span<T> x) {
    const std::size_t n = t.size(), ms = (n + 1) / 2;
    for (std::size_t i = 0; i < n; ++i)
        x[(i & 1) ? ms + i / 2 : i / 2] = t[i];
}
template <class T> std::vector<T> interleave(std::span<const T> x) {
    const std::size_t n = x.size(), ms = (n + 1) / 2;
    std::vector<T> t(n);
    for (std::size_t i = 0; i < n; ++i)
        t[i] = x[(i & 1) ? ms + i / 2 : i / 2];
    return t;
}

// One lifting step on the interleaved signal with whole-sample symmetric extension:
// t[i] += f(t[i-1] + t[i+1]) for every i of the given parity.
template <class T, class F> void liftStep(std::vector<T>& t, int parity, F f) {
    const int n = static_cast<int>(t.size());
    for (int i = parity; i < n; i += 2)
        t[i] += f(t[mirror(i - 1, n)] + t[mirror(i + 1, n)]);
}

template <class T> void forwardLine(std::span<T> x, Wavelet w) {
    const int n = static_cast<int>(x.size());
    if (n < 2) return;
    const int ms = (n + 1) / 2, md = n / 2;
    if (w == Wavelet::Cdf53) {
        std::vector<T> t(x.begin(), x.end());
        liftStep(t, 1, [](T v) { return -half(v); });
        liftStep(t, 0, [](T v) { return quarterR(v); });
        deinterleave(t, x);
    } else if (w == Wavelet::Cdf97) {
        if constexpr (std::is_same_v<T, double>) {
            std::vector<T> t(x.begin(), x.end());
            liftStep(t, 1, [](T v) { return kA * v; });
            liftStep(t, 0, [](T v) { return kB * v; });
            liftStep(t, 1, [](T v) { return kG * v; });
            liftStep(t, 0, [](T v) { return kD * v; });
            for (int i = 0; i < n; ++i)
                t[i] *= (i & 1) ? 0.5 * kK : 1.0 / kK;
            deinterleave(t, x);
        } else {
            throw UsageError("cdf97 has no reversible integer form");
        }
    } else {
        std::vector<T> s(ms), d(md);
        for (int i = 0; i < ms; ++i) {
            if (2 * i + 1 < n) {
                d[i] = x[2 * i + 1] - x[2 * i];
                s[i] = x[2 * i] + half(d[i]);
            } else {
                s[i] = x[2 * i];
            }
        }
        if (w == Wavelet::Cdf26) {
            for (int i = 0; i < md; ++i)
                d[i] += quarterR(s[std::max(i - 1, 0)] - s[std::min(i + 1, ms - 1)]);
        }
        std::copy(s.begin(), s.end(), x.begin());
        std::copy(d.begin(), d.end(), x.begin() + ms);
    }
}

template <class T> void inverseLine(std::span<T> x, Wavelet w) {
    const int n = static_cast<int>(x.size());
    if (n < 2) return;
    const int ms = (n + 1) / 2;
    if (w == Wavelet::Cdf53) {
        std::vector<T> t = interleave<T>(x);
        liftStep(t, 0, [](T v) { return -quarterR(v); });
        liftStep(t, 1, [](T v) { return half(v); });
        std::copy(t.begin(), t.end(), x.begin());
    } else if (w == Wavelet::Cdf97) {
        if constexpr (std::is_same_v<T, double>) {
            std::vector<T> t = interleave<T>(x);
            for (int i = 0; i < n; ++i)
                t[i] *= (i & 1) ? 2.0 / kK : kK;
            liftStep(t, 0, [](T v) { return -kD * v; });
            liftStep(t, 1, [](T v) { return -kG * v; });
            liftStep(t, 0, [](T v) { return -kB * v; });
            liftStep(t, 1, [](T v) { return -kA * v; });
            std::copy(t.begin(), t.end(), x.begin());
        } else {
            throw UsageError("cdf97 has no reversible integer form");
        }
    } else {
        std::vector<T> s(x.begin(), x.begin() + ms), d(x.begin() + ms, x.end());
        for (int i = 0; i < ms; ++i) {
            if (2 * i + 1 >= n) {
                x[2 * i] = s[i];
                continue;
            }
            T d1 = d[i];
            if (w == Wavelet::Cdf26) d1 -= quarterR(s[std::max(i - 1, 0)] - s[std::min(i + 1, ms - 1)]);
            const T e = s[i] - half(d1);
            x[2 * i] = e;
            x[2 * i + 1] = d1 + e;
        }
    }
}

// Applies `fn` to every line along `axis` of the active corner `a` of a brick with full dims `d`.
template <class T, class F> void forEachLine(std::span<T> data, Dims d, Dims a, int axis, F fn) {
    const std::size_t len = axis == 0 ? a.x : axis == 1 ? a.y : a.z;
    const std::size_t stride = axis == 0 ? 1 : axis == 1 ? d.x : d.x * d.y;
    std::vector<T> line(len);
    const std::size_t n1 = axis == 0 ? a.y : a.x, n2 = axis == 2 ? a.y : a.z;
    for (std::size_t j = 0; j < n2; ++j) {
        for (std::size_t i = 0; i < n1; ++i) {
            std::size_t base = 0;
            if (axis == 0) base = (j * d.y + i) * d.x;
            if (axis == 1) base = j * d.x * d.y + i;
            if (axis == 2) base = j * d.x + i;
            for (std::size_t k = 0; k < len; ++k)
                line[k] = data[base + k * stride];
            fn(std::span<T>(line));
            for (std::size_t k = 0; k < len; ++k)
                data[base + k * stride] = line[k];
        }
    }
}

template <class T> void forward3dImpl(std::span<T> data, Dims dims, int levels, Wavelet w) {
    if (data.size() != dims.count()) throw UsageError("reference transform: data size does not match dims");
    for (int l = 0; l < levels; ++l) {
        const Dims a = levelDims(dims, l);
        for (int axis = 0; axis < 3; ++axis)
            forEachLine(data, dims, a, axis, [w](std::span<T> s) { forwardLine(s, w); });
    }
}

template <class T> void inverse3dImpl(std::span<T> data, Dims dims, int levels, Wavelet w, int stopLevel) {
    if (data.size() != dims.count()) throw UsageError("reference transform: data size does not match dims");
    for (int l = levels - 1; l >= stopLevel; --l) {
        const Dims a = levelDims(dims, l);
        for (int axis = 2; axis >= 0; --axis)
            forEachLine(data, dims, a, axis, [w](std::span<T> s) { inverseLine(s, w); });
    }
}

} // namespace

namespace reference {
void forward1d(std::span<std::int32_t> line, Wavelet w) {
    forwardLine(line, w);
}
void inverse1d(std::span<std::int32_t> line, Wavelet w) {
    inverseLine(line, w);
}
void forward1d(std::span<double> line, Wavelet w) {
    forwardLine(line, w);
}
void inverse1d(std::span<double> line, Wavelet w) {
    inverseLine(line, w);
}
void forward3d(std::span<std::int32_t> data, Dims dims, int levels, Wavelet w) {
    forward3dImpl(data, dims, levels, w);
}
void forward3d(std::span<double> data, Dims dims, int levels, Wavelet w) {
    forward3dImpl(data, dims, levels, w);
}
void inverse3d(std::span<std::int32_t> data, Dims dims, int levels, Wavelet w, int stopLevel) {
    inverse3dImpl(data, dims, levels, w, stopLevel);
}
void inverse3d(std::span<double> data, Dims dims, int levels, Wavelet w, int stopLevel) {
    inverse3dImpl(data, dims, levels, w, stopLevel);
}
} // namespace reference

// ------------------------------------------------------------------------------------------ device

template <class T>
BatchMapping<T>::BatchMapping(cl::CommandQueue& queue, cl::Buffer& buffer, std::size_t count,
                              cl_map_flags flags)
    : queue_(&queue), buffer_(&buffer), count_(count) {
    cl_int err = CL_SUCCESS;
    ptr_ = static_cast<T*>(
        queue.enqueueMapBuffer(buffer, CL_TRUE, flags, 0, count * sizeof(T), nullptr, nullptr, &err));
    clCheck(err, "clEnqueueMapBuffer");
}

template <class T> BatchMapping<T>& BatchMapping<T>::operator=(BatchMapping&& o) noexcept {
    if (this != &o) {
        unmap();
        queue_ = o.queue_;
        buffer_ = o.buffer_;
        ptr_ = o.ptr_;
        count_ = o.count_;
        o.ptr_ = nullptr;
    }
    return *this;
}

template <class T> void BatchMapping<T>::unmap() noexcept {
    if (!ptr_) return;
    // An unmap cannot fail on a valid mapping; the in-order queue orders it before the next kernel.
    queue_->enqueueUnmapMemObject(*buffer_, ptr_);
    ptr_ = nullptr;
}

// Host-allocated buffers: mapping them is free on CPU devices, so bricks are written and read in place
// (ComputeContext gives large ones huge pages there).
template <class T>
BrickBatch<T>::BrickBatch(ComputeContext& cc, Dims brick, std::size_t count)
    : brick_(brick), count_(count), pitch_(pitchFor(brick.x)) {
    if (brick.count() == 0 || count == 0) throw UsageError("brick batch: empty brick or zero bricks");
    a_ = cc.allocate<T>(brickStride() * count_ + kSlack, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR);
}

template <class T>
BrickBatch<T>::BrickBatch(ComputeContext& cc, Dims brick, std::size_t count, HostBlock filled)
    : brick_(brick), count_(count), pitch_(pitchFor(brick.x)) {
    if (brick.count() == 0 || count == 0) throw UsageError("brick batch: empty brick or zero bricks");
    if (filled.size() < bytesFor(brick, count)) throw Error("internal: brick batch block too small");
    a_ = cc.adoptHost<T>(std::move(filled), brickStride() * count_ + kSlack);
}

template <class T> DeviceBuffer<T>& BrickBatch<T>::scratch(ComputeContext& cc) {
    if (current_) return a_; // b_ exists: it became current by a swap after a pass
    if (b_.size() == 0) b_ = cc.allocate<T>(a_.size(), CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR);
    return b_;
}

template <class T> BatchMapping<T> BrickBatch<T>::mapForWrite(ComputeContext& cc, bool keepContents) {
    current_ = false;
    return BatchMapping<T>(cc.queue(), a_.get(), brickStride() * count_,
                           keepContents ? CL_MAP_READ | CL_MAP_WRITE : CL_MAP_WRITE_INVALIDATE_REGION);
}

template <class T> BatchMapping<T> BrickBatch<T>::mapForRead(ComputeContext& cc) {
    return BatchMapping<T>(cc.queue(), data().get(), brickStride() * count_, CL_MAP_READ);
}

template <class T> void BrickBatch<T>::upload(ComputeContext& cc, std::span<const T> host) {
    if (host.size() != brickStride() * count_) throw Error("internal: brick batch upload size mismatch");
    current_ = false;
    cc.write(a_, host);
}

template <class T> void BrickBatch<T>::download(ComputeContext& cc, std::span<T> host) {
    if (host.size() != brickStride() * count_) throw Error("internal: brick batch download size mismatch");
    cc.read(data(), host);
}

template <class T>
LiftingTransform<T>::LiftingTransform(ComputeContext& cc, Wavelet w)
    : wavelet_(w), brickResidentDevice_(cc.profile().lifting.brickResident) {
    constexpr bool isFloat = std::is_same_v<T, float>;
    if (!isFloat && !hasIntegerForm(w)) throw UsageError("wavelet cdf97 has no reversible integer form");
    // VOLCL_LIFTING_PATH=streaming|brick forces a path for the whole process, so the codec's end-to-end
    // timings can be compared between the two kernels (bench, --profile) without a second build.
    if (const char* env = std::getenv("VOLCL_LIFTING_PATH")) {
        const std::string_view p(env);
        if (p == "streaming")
            path_ = LiftingPath::Streaming;
        else if (p == "brick")
            path_ = LiftingPath::BrickResident;
        else if (p != "auto")
            throw UsageError("VOLCL_LIFTING_PATH must be auto, streaming or brick");
    }
    // The streaming programs are built here when that path is the likely one (even a cached build costs
    // milliseconds, which belong to setup, not to the transform). The brick kernels are built on first use,
    // each variant alone: a one-shot decode runs only the inverse that writes voxels, and each program it
    // does not need costs a cached build in a process that runs once.
    if (path_ == LiftingPath::Streaming || (!brickResidentDevice_ && path_ == LiftingPath::Auto))
        buildStreaming(cc);
}

template <class T> void LiftingTransform<T>::buildStreaming(ComputeContext& cc) {
    if (streamingBuilt_) return;
    KernelDefines fwd;
    fwd.set("WAVELET", static_cast<long long>(wavelet_));
    if (std::is_same_v<T, float>) fwd.set("LIFT_FLOAT");
    KernelDefines inv = fwd;
    inv.set("LIFT_INVERSE");
    fwdX_ = cc.kernel("codec/lifting.cl", "lift_x", fwd);
    fwdYz_ = cc.kernel("codec/lifting.cl", "lift_yz", fwd);
    invX_ = cc.kernel("codec/lifting.cl", "lift_x", inv);
    invYz_ = cc.kernel("codec/lifting.cl", "lift_yz", inv);
    copy_ = cc.kernel("codec/lifting.cl", "copy_corner", fwd);
    streamingBuilt_ = true;
}

template <class T> void LiftingTransform<T>::useBrickSize(std::size_t maxN) {
    if (maxN == brickMaxN_) return;
    fwdBrick_ = invBrick_ = cl::Kernel(); // built for this LIFT_MAXN when asked for
    brickVoxels_ = {};
    brickMaxN_ = maxN;
}

template <class T> KernelDefines LiftingTransform<T>::brickDefines(bool inverse) const {
    KernelDefines d;
    d.set("WAVELET", static_cast<long long>(wavelet_));
    d.set("LIFT_MAXN", static_cast<long long>(brickMaxN_));
    if (std::is_same_v<T, float>) d.set("LIFT_FLOAT");
    if (inverse) d.set("LIFT_INVERSE");
    return d;
}

template <class T> cl::Kernel& LiftingTransform<T>::brickKernel(ComputeContext& cc, bool inverse) {
    cl::Kernel& k = inverse ? invBrick_ : fwdBrick_;
    if (!k()) k = cc.kernel("codec/lifting_brick.cl", "lift_bricks", brickDefines(inverse));
    return k;
}

template <class T>
double LiftingTransform<T>::pass(ComputeContext& cc, cl::Kernel& k, BrickBatch<T>& batch, Dims a, int axis) {
    const Dims b = batch.brick();
    const cl_uint count = static_cast<cl_uint>(batch.count());
    cl::Event ev;
    if (axis == 0) {
        setArgs(k, batch.data(), batch.scratch(cc), cl_uint(batch.pitch()), cl_uint(b.y), cl_uint(b.z),
                cl_uint(a.x), cl_uint(a.y), cl_uint(a.z), count);
        const std::size_t chunks = ((a.x + 1) / 2 + 15) / 16;
        ev = cc.launch3d(k, chunks, a.y, a.z * count, cc.profile().lifting.x);
    } else {
        setArgs(k, batch.data(), batch.scratch(cc), cl_uint(batch.pitch()), cl_uint(b.y), cl_uint(b.z),
                cl_uint(a.x), cl_uint(a.y), cl_uint(a.z), count, cl_uint(axis));
        // Dimension 0 runs over x chunks and then the in-plane coordinate (pairs along y, rows for z), so a
        // work-group streams neighbouring rows of one plane (the z pass was 3-4x slower with pairs there).
        const std::size_t chunks = (a.x + 15) / 16;
        if (axis == 1)
            ev = cc.launch3d(k, chunks * ((a.y + 1) / 2), a.z, count, cc.profile().lifting.yz);
        else
            ev = cc.launch3d(k, chunks * a.y, (a.z + 1) / 2, count, cc.profile().lifting.yz);
    }
    batch.swap();
    return eventMilliseconds(ev);
}

template <class T> double LiftingTransform<T>::copyBack(ComputeContext& cc, BrickBatch<T>& batch, Dims a) {
    const Dims b = batch.brick();
    setArgs(copy_, batch.data(), batch.scratch(cc), cl_uint(batch.pitch()), cl_uint(b.y), cl_uint(b.z),
            cl_uint(a.x), cl_uint(a.y), cl_uint(a.z), cl_uint(batch.count()));
    cl::Event ev = cc.launch3d(copy_, a.x, a.y, a.z * batch.count(), cc.profile().lifting.copy);
    batch.swap();
    return eventMilliseconds(ev);
}

template <class T> LiftingPath LiftingTransform<T>::pathFor(Dims b) const noexcept {
    if (path_ != LiftingPath::Auto) return path_;
    // The device profile says whether one work-item per brick suits the device; past kBrickResidentMaxDim
    // the private line buffers grow too large.
    const bool fits = std::max({b.x, b.y, b.z}) <= kBrickResidentMaxDim;
    return brickResidentDevice_ && fits ? LiftingPath::BrickResident : LiftingPath::Streaming;
}

template <class T>
double LiftingTransform<T>::brickResident(ComputeContext& cc, std::span<BrickBatch<T>* const> batches,
                                          bool inverse, int levels, int stopLevel, const VoxelVolume* voxels,
                                          std::size_t first,
                                          std::vector<std::vector<std::pair<double, double>>>* ranges) {
    // Largest bricks first: the kernel's counter hands bricks out in this order, so the cores end on the
    // small ones and finish together.
    std::vector<std::size_t> order(batches.size());
    std::iota(order.begin(), order.end(), std::size_t(0));
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return batches[a]->brick().count() > batches[b]->brick().count();
    });
    // Unused shape slots repeat the last batch with an empty range of bricks.
    auto slot = [&](std::size_t k) -> BrickBatch<T>& {
        return *batches[order[std::min(k, order.size() - 1)]];
    };
    cl_uint8 px{}, bx{}, by{}, bz{}, end{};
    std::size_t total = 0, maxDim = 1;
    for (std::size_t k = 0; k < kMaxShapes; ++k) {
        const Dims b = slot(k).brick();
        if (k < order.size()) {
            total += slot(k).count();
            maxDim = std::max({maxDim, b.x, b.y, b.z});
        }
        px.s[k] = cl_uint(slot(k).pitch());
        bx.s[k] = cl_uint(b.x);
        by.s[k] = cl_uint(b.y);
        bz.s[k] = cl_uint(b.z);
        end.s[k] = cl_uint(total);
    }
    // LIFT_MAXN sizes the kernel's private line buffers. Powers of two from 64 up, so a volume's interior
    // and edge bricks (and every brick of the default size) share one program: a build takes seconds.
    std::size_t maxN = 64;
    while (maxN < maxDim)
        maxN *= 2;
    if (maxN > kBrickResidentMaxDim) throw UsageError("brick-resident lifting: brick larger than 256 voxels");
    useBrickSize(maxN);
    if (brickNext_.size() == 0) brickNext_ = cc.allocate<cl_int>(1);
    cc.fill(brickNext_, cl_int(0));
    cl::Kernel& k = voxels ? voxelKernel(cc, voxels->type, inverse) : brickKernel(cc, inverse);
    setArgs(k, slot(0).data(), slot(1).data(), slot(2).data(), slot(3).data(), slot(4).data(), slot(5).data(),
            slot(6).data(), slot(7).data(), brickNext_, px, bx, by, bz, end, cl_uint(levels),
            cl_uint(std::max(stopLevel, 0)));
    DeviceBuffer<cl_ulong> offsets;
    DeviceBuffer<T> rangeBuffer;
    if (voxels) {
        // Voxel offset of each brick in the kernel's counter order.
        std::vector<cl_ulong> off;
        off.reserve(total);
        for (std::size_t b : order)
            for (const Dims& o : voxels->origins[first + b])
                off.push_back((o.z * voxels->dims.y + o.y) * voxels->dims.x + o.x);
        offsets = cc.upload<cl_ulong>(off, CL_MEM_READ_ONLY);
        // After lift_bricks' 16 arguments.
        detail::setArg(k, 16, voxels->voxels);
        detail::setArg(k, 17, offsets);
        detail::setArg(k, 18, cl_ulong(voxels->dims.x));
        detail::setArg(k, 19, cl_ulong(voxels->dims.x * voxels->dims.y));
        if (!inverse) {
            rangeBuffer = cc.allocate<T>(2 * total, CL_MEM_WRITE_ONLY);
            detail::setArg(k, 20, rangeBuffer);
        }
    }
    const DeviceProfile::Lifting& tuning = cc.profile().lifting;
    const std::size_t items = std::min<std::size_t>(total, tuning.brickItemsPerComputeUnit *
                                                               std::max(1u, cc.device().computeUnits));
    cl::Event ev = cc.launch1d(k, items, tuning.brickLocal);
    const double ms = eventMilliseconds(ev);
    if (ranges && rangeBuffer.size() > 0) {
        std::vector<T> r(2 * total);
        cc.read(rangeBuffer, std::span<T>(r));
        std::size_t c = 0;
        for (std::size_t b : order)
            for (auto& range : (*ranges)[first + b]) {
                range = {double(r[2 * c]), double(r[2 * c + 1])};
                ++c;
            }
    }
    return ms;
}

template <class T>
double LiftingTransform<T>::transformAll(ComputeContext& cc, std::span<BrickBatch<T>* const> batches,
                                         bool inverse, int levels, int stopLevel) {
    double ms = 0;
    std::vector<BrickBatch<T>*> resident;
    for (BrickBatch<T>* b : batches) {
        if (pathFor(*b) == LiftingPath::BrickResident)
            resident.push_back(b);
        else
            ms += inverse ? this->inverse(cc, *b, levels, stopLevel) : forward(cc, *b, levels);
    }
    const std::span<BrickBatch<T>* const> all(resident);
    for (std::size_t i = 0; i < all.size(); i += kMaxShapes)
        ms += brickResident(cc, all.subspan(i, std::min(kMaxShapes, all.size() - i)), inverse, levels,
                            stopLevel);
    return ms;
}

template <class T>
cl::Kernel& LiftingTransform<T>::voxelKernel(ComputeContext& cc, ScalarType type, bool inverse) {
    cl::Kernel& k = brickVoxels_[(inverse ? 4 : 0) + static_cast<std::size_t>(type)];
    if (!k()) {
        KernelDefines d = brickDefines(inverse);
        // The ray marcher's numbering (cl/common/grid_sample.h).
        static constexpr std::array<int, 4> kVoxelType = {1, 2, 3, 0}; // UInt8, UInt16, Int16, Float32
        d.set("VOXEL_TYPE", kVoxelType[static_cast<std::size_t>(type)]);
        k = cc.kernel("codec/lifting_brick.cl", "lift_bricks", d);
    }
    return k;
}

template <class T>
bool LiftingTransform<T>::canUseVoxels(std::span<BrickBatch<T>* const> batches) const noexcept {
    return std::all_of(batches.begin(), batches.end(),
                       [&](const BrickBatch<T>* b) { return pathFor(*b) == LiftingPath::BrickResident; });
}

template <class T>
void LiftingTransform<T>::checkVoxels(std::span<BrickBatch<T>* const> batches, int levels,
                                      const VoxelVolume& v) const {
    if (!canUseVoxels(batches))
        throw Error("internal: transforms from/to voxels need the brick-resident path");
    if (levels <= 0) throw Error("internal: transforms from/to voxels need at least one level");
    if (std::is_integral_v<T> && v.type == ScalarType::Float32)
        throw Error("internal: the integer transform takes integer voxels only");
    if (v.origins.size() != batches.size()) throw Error("internal: voxel origins needed per batch");
    for (std::size_t k = 0; k < batches.size(); ++k) {
        const Dims b = batches[k]->brick();
        if (v.origins[k].size() != batches[k]->count())
            throw Error("internal: a voxel origin needed per brick");
        for (const Dims& o : v.origins[k])
            if (o.x + b.x > v.dims.x || o.y + b.y > v.dims.y || o.z + b.z > v.dims.z)
                throw Error("internal: brick outside the voxel volume");
    }
}

template <class T>
double LiftingTransform<T>::withVoxels(ComputeContext& cc, std::span<BrickBatch<T>* const> batches,
                                       bool inverse, int levels, const VoxelVolume& v,
                                       std::vector<std::vector<std::pair<double, double>>>* ranges) {
    checkVoxels(batches, levels, v);
    if (ranges) {
        ranges->resize(batches.size());
        for (std::size_t k = 0; k < batches.size(); ++k)
            (*ranges)[k].assign(batches[k]->count(), {0.0, 0.0});
    }
    double ms = 0;
    for (std::size_t i = 0; i < batches.size(); i += kMaxShapes)
        ms += brickResident(cc, batches.subspan(i, std::min(kMaxShapes, batches.size() - i)), inverse, levels,
                            0, &v, i, ranges);
    return ms;
}

template <class T>
double LiftingTransform<T>::inverseToVoxels(ComputeContext& cc, std::span<BrickBatch<T>* const> batches,
                                            int levels, const VoxelVolume& target) {
    return withVoxels(cc, batches, true, levels, target, nullptr);
}

template <class T>
double LiftingTransform<T>::forwardFromVoxels(ComputeContext& cc, std::span<BrickBatch<T>* const> batches,
                                              int levels, const VoxelVolume& source,
                                              std::vector<std::vector<std::pair<double, double>>>* ranges) {
    return withVoxels(cc, batches, false, levels, source, ranges);
}

template <class T>
double LiftingTransform<T>::forward(ComputeContext& cc, std::span<BrickBatch<T>* const> batches, int levels) {
    return levels <= 0 ? 0 : transformAll(cc, batches, false, levels, 0);
}

template <class T>
double LiftingTransform<T>::inverse(ComputeContext& cc, std::span<BrickBatch<T>* const> batches, int levels,
                                    int stopLevel) {
    return levels <= stopLevel ? 0 : transformAll(cc, batches, true, levels, stopLevel);
}

template <class T> double LiftingTransform<T>::forward(ComputeContext& cc, BrickBatch<T>& batch, int levels) {
    if (levels <= 0) return 0;
    if (pathFor(batch) == LiftingPath::BrickResident) {
        BrickBatch<T>* one[] = {&batch};
        return brickResident(cc, one, false, levels, 0);
    }
    buildStreaming(cc);
    double ms = 0;
    for (int l = 0; l < levels; ++l) {
        const Dims a = levelDims(batch.brick(), l);
        ms += pass(cc, fwdX_, batch, a, 0);
        ms += pass(cc, fwdYz_, batch, a, 1);
        ms += pass(cc, fwdYz_, batch, a, 2);
        // Level 0 rewrote every voxel; deeper levels only their corner, the rest lives in the other buffer.
        if (l > 0) ms += copyBack(cc, batch, a);
    }
    return ms;
}

template <class T>
double LiftingTransform<T>::inverse(ComputeContext& cc, BrickBatch<T>& batch, int levels, int stopLevel) {
    if (levels <= stopLevel) return 0;
    if (pathFor(batch) == LiftingPath::BrickResident) {
        BrickBatch<T>* one[] = {&batch};
        return brickResident(cc, one, true, levels, stopLevel);
    }
    buildStreaming(cc);
    double ms = 0;
    for (int l = levels - 1; l >= stopLevel; --l) {
        const Dims a = levelDims(batch.brick(), l);
        ms += pass(cc, invYz_, batch, a, 2);
        ms += pass(cc, invYz_, batch, a, 1);
        ms += pass(cc, invX_, batch, a, 0);
        if (l > 0) ms += copyBack(cc, batch, a);
    }
    return ms;
}

template class BatchMapping<std::int32_t>;
template class BatchMapping<float>;
// Output volumes the inverse writes voxels into (inverseToVoxels) are mapped as well.
template class BatchMapping<std::uint8_t>;
template class BatchMapping<std::uint16_t>;
template class BatchMapping<std::int16_t>;
template class BrickBatch<std::int32_t>;
template class BrickBatch<float>;
template class LiftingTransform<std::int32_t>;
template class LiftingTransform<float>;

} // namespace volcl
