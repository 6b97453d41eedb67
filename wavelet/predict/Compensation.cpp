// Overlapped block motion compensation: windows, axis weights, mode decision and compensation (reference,
// OpenCL).
#include "wavelet/predict/Compensation.hpp"

#include "core/Error.hpp"
#include "wavelet/predict/Residual.hpp"
#include "wavelet/transform/LiftingTransform.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>

namespace volcl {

namespace {

int halfFloor(int h) {
    return (h - (h & 1)) / 2;
}

// The reference frames as float samples with their dims, for the references' inner loops.
struct Frame {
    std::vector<float> v;
    Dims d;
    explicit Frame(const Volume& vol) : v(vol.toFloat()), d(vol.dims()) {}
    double at(std::size_t x, std::size_t y, std::size_t z) const { return v[x + d.x * (y + d.y * z)]; }
    // Trilinear sample at voxel p displaced by v half voxels: the mean of the 8 clamped corners.
    double sample(int px, int py, int pz, MotionVector m) const {
        const int hx = 2 * px + m.x, hy = 2 * py + m.y, hz = 2 * pz + m.z;
        const int xs[2] = {std::clamp(halfFloor(hx), 0, int(d.x) - 1),
                           std::clamp(halfFloor(hx) + (hx & 1), 0, int(d.x) - 1)};
        const int ys[2] = {std::clamp(halfFloor(hy), 0, int(d.y) - 1),
                           std::clamp(halfFloor(hy) + (hy & 1), 0, int(d.y) - 1)};
        const int zs[2] = {std::clamp(halfFloor(hz), 0, int(d.z) - 1),
                           std::clamp(halfFloor(hz) + (hz & 1), 0, int(d.z) - 1)};
        double s = 0;
        for (int c = 0; c < 8; ++c)
            s += at(std::size_t(xs[c & 1]), std::size_t(ys[(c >> 1) & 1]), std::size_t(zs[c >> 2]));
        return s / 8;
    }
};

double predictVoxel(BlockMode mode, const Frame& r0, const Frame* r1, int x, int y, int z, MotionVector f,
                    MotionVector b, double intra) {
    switch (mode) {
    case BlockMode::Intra:
        return intra;
    case BlockMode::Zero:
        return r0.at(std::size_t(x), std::size_t(y), std::size_t(z));
    case BlockMode::Forward:
        return r0.sample(x, y, z, f);
    case BlockMode::Backward:
        return r1->sample(x, y, z, b);
    case BlockMode::Bidirectional:
        return 0.5 * (r0.sample(x, y, z, f) + r1->sample(x, y, z, b));
    }
    return 0;
}

void checkInputs(const Volume& current, const Volume& r0, const Volume* r1, BlockGrid grid,
                 const std::vector<MotionVector>& forward, const std::vector<MotionVector>* backward,
                 ModeChoice choice) {
    if (current.dims() != r0.dims() || (r1 && r1->dims() != r0.dims()) || grid.volume != r0.dims())
        throw DataError("motion compensation: frames and block grid differ in dims");
    if (forward.size() != grid.count() || (backward && backward->size() != grid.count()))
        throw DataError("motion compensation: one vector per block needed");
    if ((choice.backward || choice.bidirectional) && (!r1 || !backward))
        throw UsageError("motion compensation: backward modes need a second reference and backward vectors");
}

void checkField(const MotionField& field, const Volume& r0, const Volume* r1) {
    const std::size_t n = field.grid.count();
    if (field.grid.volume != r0.dims() || (r1 && r1->dims() != r0.dims()))
        throw DataError("motion compensation: the motion field and the reference differ in dims");
    if (r1 && r1->type() != r0.type()) throw DataError("motion compensation: the references differ in type");
    if (field.modes.size() != n || field.forward.size() != n || field.intraValue.size() != n ||
        (field.bidirectional() && field.backward.size() != n))
        throw DataError("motion compensation: the motion field is incomplete");
    for (BlockMode m : field.modes) {
        if (static_cast<int>(m) >= kBlockModeCount)
            throw DataError("motion compensation: unknown block mode");
        if ((m == BlockMode::Backward || m == BlockMode::Bidirectional) && (!r1 || !field.bidirectional()))
            throw DataError("motion compensation: a backward mode needs a second reference");
    }
}

bool allowed(ModeChoice c, BlockMode m) {
    switch (m) {
    case BlockMode::Intra:
        return c.intra;
    case BlockMode::Zero:
        return c.zero;
    case BlockMode::Forward:
        return c.forward;
    case BlockMode::Backward:
        return c.backward;
    case BlockMode::Bidirectional:
        return c.bidirectional;
    }
    return false;
}

} // namespace

double overlapWindow(std::size_t blockSize, std::size_t overlap, std::size_t t) noexcept {
    if (overlap == 0) return t < blockSize ? 1.0 : 0.0;
    const double ramp = 2.0 * double(overlap);
    if (t < 2 * overlap) return 0.5 * (1 - std::cos(std::numbers::pi * (double(t) + 0.5) / ramp));
    if (t >= blockSize && t < blockSize + 2 * overlap)
        return 0.5 * (1 - std::cos(std::numbers::pi * (double(blockSize + 2 * overlap - t) - 0.5) / ramp));
    return t < blockSize + 2 * overlap ? 1.0 : 0.0;
}

AxisWeights axisWeights(std::size_t n, std::size_t blockSize) {
    const std::size_t o = overlapFor(blockSize);
    const std::size_t nb = (n + blockSize - 1) / blockSize;
    AxisWeights a;
    a.first.resize(n);
    a.w0.resize(n);
    a.w1.resize(n);
    auto window = [&](std::size_t b, std::size_t x) {
        return overlapWindow(blockSize, o, x + o - b * blockSize);
    };
    for (std::size_t x = 0; x < n; ++x) {
        const std::size_t own = x / blockSize, offset = x - own * blockSize;
        std::size_t lo = own;
        bool pair = false;
        if (offset < o && own > 0) {
            lo = own - 1;
            pair = true;
        } else if (offset + o >= blockSize && own + 1 < nb) {
            pair = true;
        }
        const double w0 = window(lo, x), w1 = pair ? window(lo + 1, x) : 0.0;
        a.first[x] = int(lo);
        a.w0[x] = w0 / (w0 + w1);
        a.w1[x] = w1 / (w0 + w1);
    }
    return a;
}

BlockMode cheapestMode(const ModeCosts& c) noexcept {
    static constexpr BlockMode order[] = {BlockMode::Zero, BlockMode::Forward, BlockMode::Backward,
                                          BlockMode::Bidirectional, BlockMode::Intra};
    BlockMode best = BlockMode::Intra;
    double bestCost = std::numeric_limits<double>::infinity();
    bool any = false;
    for (BlockMode m : order) {
        const double v = c[static_cast<int>(m)];
        if (!std::isinf(v) && (!any || v < bestCost)) {
            best = m;
            bestCost = v;
            any = true;
        }
    }
    return best;
}

MotionField decideModesReference(const Volume& current, const Volume& reference0, const Volume* reference1,
                                 BlockGrid grid, const std::vector<MotionVector>& forward,
                                 const std::vector<MotionVector>* backward, ModeChoice choice,
                                 std::vector<ModeCosts>* costs) {
    checkInputs(current, reference0, reference1, grid, forward, backward, choice);
    const Frame cur(current), r0(reference0);
    const std::unique_ptr<Frame> r1 = reference1 ? std::make_unique<Frame>(*reference1) : nullptr;
    MotionField f;
    f.grid = grid;
    f.forward = forward;
    if (backward && (choice.backward || choice.bidirectional)) f.backward = *backward;
    const Dims nb = grid.blocks();
    const std::size_t B = grid.size;
    f.modes.resize(nb.count());
    f.intraValue.resize(nb.count());
    if (costs) costs->assign(nb.count(), {});
    const Dims d = grid.volume;
    for (std::size_t bz = 0, b = 0; bz < nb.z; ++bz)
        for (std::size_t by = 0; by < nb.y; ++by)
            for (std::size_t bx = 0; bx < nb.x; ++bx, ++b) {
                const std::size_t x0 = bx * B, y0 = by * B, z0 = bz * B;
                const std::size_t x1 = std::min(d.x, x0 + B), y1 = std::min(d.y, y0 + B),
                                  z1 = std::min(d.z, z0 + B);
                double sum = 0;
                for (std::size_t z = z0; z < z1; ++z)
                    for (std::size_t y = y0; y < y1; ++y)
                        for (std::size_t x = x0; x < x1; ++x)
                            sum += cur.at(x, y, z);
                const double mean = sum / double((x1 - x0) * (y1 - y0) * (z1 - z0));
                f.intraValue[b] = static_cast<float>(mean);
                ModeCosts c;
                c.fill(std::numeric_limits<double>::infinity());
                for (int m = 0; m < kBlockModeCount; ++m) {
                    const BlockMode mode = static_cast<BlockMode>(m);
                    if (!allowed(choice, mode)) continue;
                    double e = 0;
                    for (std::size_t z = z0; z < z1; ++z)
                        for (std::size_t y = y0; y < y1; ++y)
                            for (std::size_t x = x0; x < x1; ++x) {
                                const double p = predictVoxel(
                                    mode, r0, r1.get(), int(x), int(y), int(z), forward[b],
                                    backward ? (*backward)[b] : MotionVector{}, double(f.intraValue[b]));
                                const double diff = cur.at(x, y, z) - p;
                                e += diff * diff;
                            }
                    c[m] = e;
                }
                f.modes[b] = cheapestMode(c);
                if (costs) (*costs)[b] = c;
            }
    return f;
}

Volume compensateReference(const MotionField& field, const Volume& reference0, const Volume* reference1) {
    checkField(field, reference0, reference1);
    const Frame r0(reference0);
    const std::unique_ptr<Frame> r1 = reference1 ? std::make_unique<Frame>(*reference1) : nullptr;
    const Dims d = field.grid.volume, nb = field.grid.blocks();
    const AxisWeights ax = axisWeights(d.x, field.grid.size), ay = axisWeights(d.y, field.grid.size),
                      az = axisWeights(d.z, field.grid.size);
    Volume out(d, ScalarType::Float32);
    out.spacing = reference0.spacing;
    out.origin = reference0.origin;
    auto o = out.values<float>();
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x) {
                double p = 0;
                for (int c = 0; c < 8; ++c) {
                    const double wx = (c & 1) ? ax.w1[x] : ax.w0[x], wy = (c & 2) ? ay.w1[y] : ay.w0[y],
                                 wz = (c & 4) ? az.w1[z] : az.w0[z];
                    const double w = wx * wy * wz;
                    if (w == 0) continue;
                    const std::size_t b = std::size_t(ax.first[x] + (c & 1)) +
                                          nb.x * (std::size_t(ay.first[y] + ((c >> 1) & 1)) +
                                                  nb.y * std::size_t(az.first[z] + (c >> 2)));
                    p += w * predictVoxel(field.modes[b], r0, r1.get(), int(x), int(y), int(z),
                                          field.forward[b],
                                          field.bidirectional() ? field.backward[b] : MotionVector{},
                                          double(field.intraValue[b]));
                }
                o[out.index(x, y, z)] = static_cast<float>(p);
            }
    return out;
}

// ------------------------------------------------------------------------------ OpenCL

namespace {

std::vector<cl_int4> packVectors(const std::vector<MotionVector>& v, std::size_t n) {
    std::vector<cl_int4> out(n, cl_int4{{0, 0, 0, 0}});
    for (std::size_t i = 0; i < v.size() && i < n; ++i)
        out[i] = {{v[i].x, v[i].y, v[i].z, 0}};
    return out;
}

cl_int4 dims4(Dims d) {
    return {{cl_int(d.x), cl_int(d.y), cl_int(d.z), 0}};
}

// A read-only device view of a volume's voxels in its host memory (CL_MEM_USE_HOST_PTR: no copy on CPU
// devices). The kernels only read it, so the const volume is not changed.
DeviceBuffer<std::byte> wrapVoxels(ComputeContext& cc, const Volume& v) {
    const std::span<const std::byte> b = v.bytes();
    return cc.wrapHost(std::span<std::byte>(const_cast<std::byte*>(b.data()), b.size()), CL_MEM_READ_ONLY);
}

// The compensation kernels' view of a motion field: modes, vectors, intra values, and per-axis tables (x
// then y then z) of the first covering block and the two normalised weights. The device works in these
// host arrays (CL_MEM_USE_HOST_PTR) rather than in uploaded copies: no blocking write per table, each of
// which waits for the device's threads (long waits on a machine shared with other jobs). They must outlive
// the launch that reads them.
struct FieldBuffers {
    std::vector<cl_uchar> modeTable;
    std::vector<cl_int4> fwdTable, bwdTable;
    std::vector<cl_float> intraTable;
    std::vector<cl_int> firstTable;
    std::vector<cl_float2> weightTable;
    DeviceBuffer<cl_uchar> modes;
    DeviceBuffer<cl_int4> fwd, bwd;
    DeviceBuffer<cl_float> intra;
    DeviceBuffer<cl_int> first;
    DeviceBuffer<cl_float2> weights;

    FieldBuffers(ComputeContext& cc, const MotionField& field) {
        const Dims d = field.grid.volume;
        const std::size_t n = field.grid.count();
        modeTable.resize(n);
        for (std::size_t b = 0; b < n; ++b)
            modeTable[b] = static_cast<cl_uchar>(field.modes[b]);
        fwdTable = packVectors(field.forward, n);
        bwdTable = packVectors(field.backward, n);
        intraTable = field.intraValue;
        for (std::size_t len : {d.x, d.y, d.z}) {
            const AxisWeights a = axisWeights(len, field.grid.size);
            for (std::size_t i = 0; i < len; ++i) {
                firstTable.push_back(a.first[i]);
                weightTable.push_back({{float(a.w0[i]), float(a.w1[i])}});
            }
        }
        modes = cc.wrapHost(std::span(modeTable), CL_MEM_READ_ONLY);
        fwd = cc.wrapHost(std::span(fwdTable), CL_MEM_READ_ONLY);
        bwd = cc.wrapHost(std::span(bwdTable), CL_MEM_READ_ONLY);
        intra = cc.wrapHost(std::span(intraTable), CL_MEM_READ_ONLY);
        first = cc.wrapHost(std::span(firstTable), CL_MEM_READ_ONLY);
        weights = cc.wrapHost(std::span(weightTable), CL_MEM_READ_ONLY);
    }
    FieldBuffers(const FieldBuffers&) = delete; // the buffers point into this object's arrays
    FieldBuffers& operator=(const FieldBuffers&) = delete;
};

// The row kernels' groups of 8 voxels along x start `overlap` mod 8 below a multiple of 8, so that every
// group's voxels share their first covering block (see obmc8 in cl/codec/motion.cl): the first group's start,
// and the number of groups over a row of n voxels.
cl_int rowStart(std::size_t blockSize) {
    const int o = int(overlapFor(blockSize) % 8);
    return o == 0 ? 0 : o - 8;
}
std::size_t rowGroups(std::size_t n, std::size_t blockSize) {
    return (n + std::size_t(-rowStart(blockSize)) + 7) / 8;
}

} // namespace

MotionCompensator::MotionCompensator(ComputeContext& cc) {
    costsKernel_ = cc.kernel("codec/motion.cl", "motion_mode_costs");
    compensateKernel_ = cc.kernel("codec/motion.cl", "motion_compensate");
}

cl::Kernel& MotionCompensator::compensateRows(ComputeContext& cc, ScalarType type) {
    std::optional<cl::Kernel>& k = compensateRows_[static_cast<std::size_t>(type)];
    if (!k) {
        KernelDefines d;
        d.set("REF_TYPE", static_cast<int>(type)); // the kernel's ref_t follows ScalarType's order
        k = cc.kernel("codec/motion.cl", "motion_compensate_rows", d);
    }
    return *k;
}

cl::Kernel& MotionCompensator::reconstructRows(ComputeContext& cc, ScalarType type, ScalarType frameType,
                                               bool roundPrediction) {
    const std::size_t key = (static_cast<std::size_t>(type) * 4 + static_cast<std::size_t>(frameType)) * 2 +
                            (roundPrediction ? 1 : 0);
    std::optional<cl::Kernel>& k = reconstructRows_[key];
    if (!k) {
        KernelDefines d;
        d.set("REF_TYPE", static_cast<int>(type));
        d.set("OUT_TYPE", static_cast<int>(frameType));
        d.set("ROUND_PREDICTION", roundPrediction ? 1 : 0);
        k = cc.kernel("codec/motion.cl", "motion_reconstruct_rows", d);
    }
    return *k;
}

MotionField MotionCompensator::decideModes(ComputeContext& cc, const Volume& current,
                                           const Volume& reference0, const Volume* reference1, BlockGrid grid,
                                           const std::vector<MotionVector>& forward,
                                           const std::vector<MotionVector>* backward, ModeChoice choice,
                                           std::vector<ModeCosts>* costs) {
    checkInputs(current, reference0, reference1, grid, forward, backward, choice);
    const std::size_t n = grid.count();
    const std::vector<float> cur = current.toFloat(), r0 = reference0.toFloat();
    const std::vector<float> r1 = reference1 ? reference1->toFloat() : std::vector<float>(1, 0.0f);
    auto curB = cc.upload(cur, CL_MEM_READ_ONLY), r0B = cc.upload(r0, CL_MEM_READ_ONLY),
         r1B = cc.upload(r1, CL_MEM_READ_ONLY);
    auto fwdB = cc.upload(packVectors(forward, n), CL_MEM_READ_ONLY);
    auto bwdB =
        cc.upload(packVectors(backward ? *backward : std::vector<MotionVector>{}, n), CL_MEM_READ_ONLY);
    auto costB = cc.allocate<cl_float>(n * kBlockModeCount);
    auto meanB = cc.allocate<cl_float>(n);
    const cl_int modeMask = (choice.intra ? 1 : 0) | (choice.zero ? 2 : 0) | (choice.forward ? 4 : 0) |
                            (choice.backward ? 8 : 0) | (choice.bidirectional ? 16 : 0);
    setArgs(costsKernel_, curB, r0B, r1B, dims4(grid.volume), cl_int(grid.size), dims4(grid.blocks()), fwdB,
            bwdB, modeMask, costB, meanB);
    kernelMs_ = eventMilliseconds(cc.launch1d(costsKernel_, n, cc.profile().motion.costs));
    const std::vector<float> c = cc.download(costB), means = cc.download(meanB);
    MotionField f;
    f.grid = grid;
    f.forward = forward;
    if (backward && (choice.backward || choice.bidirectional)) f.backward = *backward;
    f.modes.resize(n);
    f.intraValue = means;
    if (costs) costs->assign(n, {});
    for (std::size_t b = 0; b < n; ++b) {
        ModeCosts mc;
        for (int m = 0; m < kBlockModeCount; ++m)
            mc[m] = (modeMask >> m) & 1 ? double(c[b * kBlockModeCount + m])
                                        : std::numeric_limits<double>::infinity();
        f.modes[b] = cheapestMode(mc);
        if (costs) (*costs)[b] = mc;
    }
    return f;
}

Volume MotionCompensator::compensate(ComputeContext& cc, const MotionField& field, const Volume& reference0,
                                     const Volume* reference1) {
    checkField(field, reference0, reference1);
    const Dims d = field.grid.volume;
    const FieldBuffers fb(cc, field);
    Volume out(d, ScalarType::Float32);
    out.spacing = reference0.spacing;
    out.origin = reference0.origin;
    auto outB = cc.wrapHost(out.values<float>());
    if (field.grid.size >= 8) {
        // The references as they are (no float copy), in host memory the device works in.
        const DeviceBuffer<std::byte> r0B = wrapVoxels(cc, reference0),
                                      r1B = reference1 ? wrapVoxels(cc, *reference1) : r0B;
        cl::Kernel& k = compensateRows(cc, reference0.type());
        setArgs(k, r0B, r1B, dims4(d), dims4(field.grid.blocks()), rowStart(field.grid.size), fb.modes,
                fb.fwd, fb.bwd, fb.intra, fb.first, fb.weights, outB);
        kernelMs_ = eventMilliseconds(
            cc.launch3d(k, rowGroups(d.x, field.grid.size), d.y, d.z, cc.profile().motion.rows));
    } else {
        // Blocks below 8: one work-item per voxel on float copies of the references (8 voxels along x span
        // more than a block and its neighbour there).
        std::vector<float> r0 = reference0.toFloat();
        std::vector<float> r1 = reference1 ? reference1->toFloat() : std::vector<float>(1, 0.0f);
        auto r0B = cc.wrapHost(std::span(r0), CL_MEM_READ_ONLY),
             r1B = cc.wrapHost(std::span(r1), CL_MEM_READ_ONLY);
        setArgs(compensateKernel_, r0B, r1B, dims4(d), dims4(field.grid.blocks()), fb.modes, fb.fwd, fb.bwd,
                fb.intra, fb.first, fb.weights, outB);
        kernelMs_ =
            eventMilliseconds(cc.launch3d(compensateKernel_, d.x, d.y, d.z, cc.profile().motion.voxels));
    }
    // Mapping makes the kernel's writes visible in `out`.
    BatchMapping<float> visible(cc.queue(), outB.get(), d.count(), CL_MAP_READ);
    return out;
}

Volume MotionCompensator::reconstruct(ComputeContext& cc, const MotionField& field, const Volume& reference0,
                                      const Volume* reference1, const Volume& residual, ScalarType frameType,
                                      bool roundPrediction) {
    checkField(field, reference0, reference1);
    if (residual.dims() != reference0.dims() || residual.type() != ScalarType::Float32)
        throw DataError("motion compensation: the residual must be Float32 on the reference's grid");
    const ScalarType type = frameType;
    if (field.grid.size < 8)
        return codec::addResidual(codec::quantisedPrediction(compensate(cc, field, reference0, reference1),
                                                             roundPrediction ? type : ScalarType::Float32),
                                  residual, type);
    const Dims d = field.grid.volume;
    const FieldBuffers fb(cc, field);
    Volume out(d, type);
    out.spacing = residual.spacing;
    out.origin = residual.origin;
    const DeviceBuffer<std::byte> r0B = wrapVoxels(cc, reference0),
                                  r1B = reference1 ? wrapVoxels(cc, *reference1) : r0B,
                                  resB = wrapVoxels(cc, residual);
    auto outB = cc.wrapHost(out.bytes());
    cl::Kernel& k = reconstructRows(cc, reference0.type(), type, roundPrediction);
    setArgs(k, r0B, r1B, dims4(d), dims4(field.grid.blocks()), rowStart(field.grid.size), fb.modes, fb.fwd,
            fb.bwd, fb.intra, fb.first, fb.weights, resB, outB);
    kernelMs_ = eventMilliseconds(
        cc.launch3d(k, rowGroups(d.x, field.grid.size), d.y, d.z, cc.profile().motion.rows));
    // Mapping makes the kernel's writes visible in `out`.
    BatchMapping<std::uint8_t> visible(cc.queue(), outB.get(), out.byteSize(), CL_MAP_READ);
    return out;
}

} // namespace volcl
