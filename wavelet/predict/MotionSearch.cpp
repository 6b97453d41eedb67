// Block-matching motion estimation: search samples and pyramid, search stages, C++ reference, OpenCL driver.
#include "wavelet/predict/MotionSearch.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

namespace volcl {

namespace {

// One pass of the search: at `level`, candidates centre + step * d for d in [-radius, radius]^3, components
// limited to |v| <= limit (half-voxel units of that level). The centre of stage i > 0 is the previous
// stage's best, doubled when the level gets finer.
struct SearchStage {
    int level, radius, step, limit;
};

int ceilDiv(int a, int b) {
    return (a + b - 1) / b;
}

// Blocks on a coarse level keep their pitch (block size >> level) but match over at least 4^3 voxels:
// a 2^3 block is too small to tell vectors apart.
std::size_t matchExtent(std::size_t blockSize, int level) {
    return std::max<std::size_t>(blockSize >> level, std::min<std::size_t>(blockSize, 4));
}

std::vector<SearchStage> searchStages(const MotionSearchOptions& o) {
    std::vector<SearchStage> stages;
    const int top = o.method == MotionSearchMethod::Hierarchical ? hierarchyLevels(o) : 0;
    const int coarseRadius = ceilDiv(o.radius, 1 << top);
    stages.push_back({top, coarseRadius, 2, 2 * coarseRadius});
    for (int l = top - 1; l >= 0; --l)
        stages.push_back({l, 1, 2, 2 * ceilDiv(o.radius, 1 << l)});
    if (o.halfVoxel && o.radius > 0) stages.push_back({0, 1, 1, 2 * o.radius});
    return stages;
}

// The centre of the next stage from the best vector of the previous one.
MotionVector nextCentre(MotionVector best, const SearchStage& from, const SearchStage& to) {
    const int scale = from.level > to.level ? 2 : 1;
    auto c = [&](int v) { return static_cast<std::int16_t>(std::clamp(v * scale, -to.limit, to.limit)); };
    return {c(best.x), c(best.y), c(best.z)};
}

bool better(std::uint64_t ca, MotionVector a, std::uint64_t cb, MotionVector b) {
    if (ca != cb) return ca < cb;
    if (a.l1() != b.l1()) return a.l1() < b.l1();
    if (a.z != b.z) return a.z < b.z;
    if (a.y != b.y) return a.y < b.y;
    return a.x < b.x;
}

int halfFloor(int h) {
    return (h - (h & 1)) / 2;
}

// 8 x the trilinear sample of `ref` at voxel p displaced by v half voxels, clamp-to-edge.
std::int64_t sample8(const std::vector<std::int32_t>& ref, Dims d, int px, int py, int pz, MotionVector v) {
    const int hx = 2 * px + v.x, hy = 2 * py + v.y, hz = 2 * pz + v.z;
    const int xs[2] = {std::clamp(halfFloor(hx), 0, int(d.x) - 1),
                       std::clamp(halfFloor(hx) + (hx & 1), 0, int(d.x) - 1)};
    const int ys[2] = {std::clamp(halfFloor(hy), 0, int(d.y) - 1),
                       std::clamp(halfFloor(hy) + (hy & 1), 0, int(d.y) - 1)};
    const int zs[2] = {std::clamp(halfFloor(hz), 0, int(d.z) - 1),
                       std::clamp(halfFloor(hz) + (hz & 1), 0, int(d.z) - 1)};
    std::int64_t s = 0;
    for (int c = 0; c < 8; ++c)
        s += ref[std::size_t(xs[c & 1]) +
                 d.x * (std::size_t(ys[(c >> 1) & 1]) + d.y * std::size_t(zs[c >> 2]))];
    return s;
}

std::uint64_t blockCost(const MotionSearchSamples& s, int level, std::size_t pitch, std::size_t extent,
                        std::size_t bx, std::size_t by, std::size_t bz, MotionVector v, MotionCost cost) {
    const Dims d = s.dims[level];
    const auto& cur = s.current[level];
    const auto& ref = s.reference[level];
    std::uint64_t total = 0;
    for (std::size_t z = bz * pitch; z < std::min(d.z, bz * pitch + extent); ++z)
        for (std::size_t y = by * pitch; y < std::min(d.y, by * pitch + extent); ++y)
            for (std::size_t x = bx * pitch; x < std::min(d.x, bx * pitch + extent); ++x) {
                const std::int64_t diff = 8 * std::int64_t(cur[x + d.x * (y + d.y * z)]) -
                                          sample8(ref, d, int(x), int(y), int(z), v);
                total += cost == MotionCost::Ssd ? std::uint64_t(diff * diff) : std::uint64_t(std::abs(diff));
            }
    return total;
}

std::vector<std::int32_t> downsample(const std::vector<std::int32_t>& in, Dims d, Dims& out) {
    out = {(d.x + 1) / 2, (d.y + 1) / 2, (d.z + 1) / 2};
    std::vector<std::int32_t> r(out.count());
    for (std::size_t z = 0; z < out.z; ++z)
        for (std::size_t y = 0; y < out.y; ++y)
            for (std::size_t x = 0; x < out.x; ++x) {
                std::int64_t sum = 0;
                for (int c = 0; c < 8; ++c) {
                    const std::size_t xi = std::min(2 * x + (c & 1), d.x - 1),
                                      yi = std::min(2 * y + ((c >> 1) & 1), d.y - 1),
                                      zi = std::min(2 * z + (c >> 2), d.z - 1);
                    sum += in[xi + d.x * (yi + d.y * zi)];
                }
                r[x + out.x * (y + out.y * z)] = static_cast<std::int32_t>((sum + 4) >> 3);
            }
    return r;
}

std::vector<std::int32_t> integerSamples(const Volume& v, double lo, double scale) {
    std::vector<std::int32_t> out(v.voxelCount());
    if (v.type() == ScalarType::Float32) {
        const auto f = v.values<float>();
        for (std::size_t i = 0; i < out.size(); ++i)
            out[i] = static_cast<std::int32_t>(std::lround((double(f[i]) - lo) * scale));
    } else {
        for (std::size_t i = 0; i < out.size(); ++i)
            out[i] = static_cast<std::int32_t>(v.valueAt(i));
    }
    return out;
}

} // namespace

void validate(const MotionSearchOptions& o) {
    if (o.blockSize < 2 || o.blockSize > 32 || !std::has_single_bit(o.blockSize))
        throw UsageError("motion block size " + std::to_string(o.blockSize) +
                         " must be a power of two in 2..32");
    if (o.radius < 0 || o.radius > 15)
        throw UsageError("motion search radius " + std::to_string(o.radius) + " must be in 0..15");
}

int hierarchyLevels(const MotionSearchOptions& o) noexcept {
    int levels = 0;
    while (levels < 2 && (o.blockSize >> (levels + 1)) >= 2 && (o.radius >> (levels + 1)) >= 1)
        ++levels;
    return levels;
}

MotionSearchSamples prepareSearchSamples(const Volume& current, const Volume& reference, int levels) {
    if (current.dims() != reference.dims() || current.type() != reference.type())
        throw DataError("motion search: the frames differ in dims or type");
    double lo = 0, scale = 1;
    if (current.type() == ScalarType::Float32) {
        double mn = std::numeric_limits<double>::infinity(), mx = -mn;
        for (const Volume* v : {&current, &reference})
            for (float f : v->values<float>()) {
                if (!std::isfinite(f)) throw DataError("motion search: a frame holds NaN or Inf");
                mn = std::min(mn, double(f));
                mx = std::max(mx, double(f));
            }
        lo = mn;
        scale = mx > mn ? 65535.0 / (mx - mn) : 0.0;
    }
    MotionSearchSamples s;
    s.dims.push_back(current.dims());
    s.current.push_back(integerSamples(current, lo, scale));
    s.reference.push_back(integerSamples(reference, lo, scale));
    for (int l = 0; l < levels; ++l) {
        Dims d;
        s.current.push_back(downsample(s.current[l], s.dims[l], d));
        s.reference.push_back(downsample(s.reference[l], s.dims[l], d));
        s.dims.push_back(d);
    }
    return s;
}

MotionSearchResult searchMotionReference(const MotionSearchSamples& s, const MotionSearchOptions& o) {
    validate(o);
    const std::vector<SearchStage> stages = searchStages(o);
    if (s.dims.size() <= std::size_t(stages.front().level))
        throw Error("internal: motion samples lack levels");
    MotionSearchResult r;
    r.grid = {s.dims[0], o.blockSize};
    const Dims nb = r.grid.blocks();
    r.vectors.assign(nb.count(), {});
    r.costs.assign(nb.count(), 0);
    for (std::size_t si = 0; si < stages.size(); ++si) {
        const SearchStage& st = stages[si];
        const std::size_t pitch = o.blockSize >> st.level, extent = matchExtent(o.blockSize, st.level);
        for (std::size_t bz = 0, b = 0; bz < nb.z; ++bz)
            for (std::size_t by = 0; by < nb.y; ++by)
                for (std::size_t bx = 0; bx < nb.x; ++bx, ++b) {
                    const MotionVector c =
                        si == 0 ? MotionVector{} : nextCentre(r.vectors[b], stages[si - 1], st);
                    bool any = false;
                    std::uint64_t best = 0;
                    MotionVector bestV = c;
                    for (int dz = -st.radius; dz <= st.radius; ++dz)
                        for (int dy = -st.radius; dy <= st.radius; ++dy)
                            for (int dx = -st.radius; dx <= st.radius; ++dx) {
                                const MotionVector v{std::int16_t(c.x + st.step * dx),
                                                     std::int16_t(c.y + st.step * dy),
                                                     std::int16_t(c.z + st.step * dz)};
                                if (std::abs(v.x) > st.limit || std::abs(v.y) > st.limit ||
                                    std::abs(v.z) > st.limit)
                                    continue;
                                const std::uint64_t cost =
                                    blockCost(s, st.level, pitch, extent, bx, by, bz, v, o.cost);
                                if (!any || better(cost, v, best, bestV)) {
                                    best = cost;
                                    bestV = v;
                                    any = true;
                                }
                            }
                    r.vectors[b] = bestV;
                    r.costs[b] = best;
                }
    }
    return r;
}

MotionEstimator::MotionEstimator(ComputeContext& cc, const MotionSearchOptions& options) : options_(options) {
    validate(options_);
    KernelDefines whole, half;
    whole.set("HALF_STEP", 0).set("COST_SSD", options_.cost == MotionCost::Ssd ? 1 : 0);
    half.set("HALF_STEP", 1).set("COST_SSD", options_.cost == MotionCost::Ssd ? 1 : 0);
    searchKernel_ = cc.kernel("codec/motion.cl", "motion_search", whole);
    halfKernel_ = cc.kernel("codec/motion.cl", "motion_search", half);
    reduceKernel_ = cc.kernel("codec/motion.cl", "motion_search_reduce", whole);
}

MotionSearchResult MotionEstimator::search(ComputeContext& cc, const Volume& current,
                                           const Volume& reference) {
    const int levels = options_.method == MotionSearchMethod::Hierarchical ? hierarchyLevels(options_) : 0;
    return search(cc, prepareSearchSamples(current, reference, levels));
}

MotionSearchResult MotionEstimator::search(ComputeContext& cc, const MotionSearchSamples& s) {
    const std::vector<SearchStage> stages = searchStages(options_);
    if (s.dims.size() <= std::size_t(stages.front().level))
        throw Error("internal: motion samples lack levels");
    MotionSearchResult r;
    r.grid = {s.dims[0], options_.blockSize};
    const Dims nb = r.grid.blocks();
    const std::size_t nblocks = nb.count();
    if (nblocks > std::size_t(std::numeric_limits<int>::max()) / 1024)
        throw DataError("motion search: volume too large for one search");
    r.vectors.assign(nblocks, {});
    r.costs.assign(nblocks, 0);
    std::vector<DeviceBuffer<std::int32_t>> cur, ref;
    for (std::size_t l = 0; l < s.dims.size(); ++l) {
        cur.push_back(cc.upload(s.current[l], CL_MEM_READ_ONLY));
        ref.push_back(cc.upload(s.reference[l], CL_MEM_READ_ONLY));
    }
    int maxPairs = 0;
    for (const SearchStage& st : stages)
        maxPairs = std::max(maxPairs, (2 * st.radius + 1) * (2 * st.radius + 1));
    DeviceBuffer<cl_ulong> pairCost = cc.allocate<cl_ulong>(nblocks * std::size_t(maxPairs));
    DeviceBuffer<cl_int4> pairVector = cc.allocate<cl_int4>(nblocks * std::size_t(maxPairs));
    DeviceBuffer<cl_ulong> bestCost = cc.allocate<cl_ulong>(nblocks);
    DeviceBuffer<cl_int4> bestVector = cc.allocate<cl_int4>(nblocks);
    DeviceBuffer<cl_int4> centres = cc.allocate<cl_int4>(nblocks);
    std::vector<cl_int4> hostCentres(nblocks), hostBest(nblocks);
    const cl_int4 blocks{{cl_int(nb.x), cl_int(nb.y), cl_int(nb.z), 0}};
    kernelMs_ = 0;
    for (std::size_t si = 0; si < stages.size(); ++si) {
        const SearchStage& st = stages[si];
        for (std::size_t b = 0; b < nblocks; ++b) {
            const MotionVector c = si == 0 ? MotionVector{} : nextCentre(r.vectors[b], stages[si - 1], st);
            hostCentres[b] = {{c.x, c.y, c.z, 0}};
        }
        cc.write(centres, std::span<const cl_int4>(hostCentres));
        const Dims d = s.dims[st.level];
        const cl_int4 dims{{cl_int(d.x), cl_int(d.y), cl_int(d.z), 0}};
        const int pairs = (2 * st.radius + 1) * (2 * st.radius + 1);
        cl::Kernel& k = st.step == 1 ? halfKernel_ : searchKernel_;
        setArgs(k, cur[st.level], ref[st.level], dims, cl_int(options_.blockSize >> st.level),
                cl_int(matchExtent(options_.blockSize, st.level)), blocks, centres, cl_int(st.radius),
                cl_int(st.step), cl_int(st.limit), pairCost, pairVector);
        kernelMs_ +=
            eventMilliseconds(cc.launch1d(k, nblocks * std::size_t(pairs), cc.profile().motion.search));
        setArgs(reduceKernel_, pairCost, pairVector, cl_int(pairs), cl_int(nblocks), bestCost, bestVector);
        kernelMs_ += eventMilliseconds(cc.launch1d(reduceKernel_, nblocks, cc.profile().motion.reduce));
        cc.read(bestVector, std::span<cl_int4>(hostBest));
        for (std::size_t b = 0; b < nblocks; ++b)
            r.vectors[b] = {std::int16_t(hostBest[b].s[0]), std::int16_t(hostBest[b].s[1]),
                            std::int16_t(hostBest[b].s[2])};
    }
    const std::vector<cl_ulong> costs = cc.download(bestCost);
    std::copy(costs.begin(), costs.end(), r.costs.begin());
    return r;
}

} // namespace volcl
