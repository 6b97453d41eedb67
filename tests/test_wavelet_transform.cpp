// Lifting transforms: references are perfect-reconstruction, kernels match the references (bit-exact for
// the integer forms), on odd, prime, tiny and extreme inputs.
#include "core/Volume.hpp"
#include "tests/TestUtil.hpp"
#include "wavelet/transform/LiftingTransform.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <map>
#include <memory>
#include <random>
#include <tuple>
#include <vector>

using namespace volcl;

namespace {

const Wavelet kIntegerWavelets[] = {Wavelet::Cdf53, Wavelet::Haar, Wavelet::Cdf26};
// Both kernel paths must equal the references: the streaming passes and the brick-resident kernel.
const LiftingPath kPaths[] = {LiftingPath::Streaming, LiftingPath::BrickResident};
const char* pathName(LiftingPath p) {
    return p == LiftingPath::Streaming       ? "streaming"
           : p == LiftingPath::BrickResident ? "brick-resident"
                                             : "auto";
}
const Wavelet kAllWavelets[] = {Wavelet::Cdf53, Wavelet::Cdf97, Wavelet::Haar, Wavelet::Cdf26};

std::vector<std::int32_t> randomInts(std::size_t n, std::int32_t lo, std::int32_t hi, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::int32_t> dist(lo, hi);
    std::vector<std::int32_t> v(n);
    for (auto& x : v)
        x = dist(rng);
    return v;
}

// Packs `count` bricks (each brick.count() values, x fastest) into the batch layout and back.
template <class T> std::vector<T> pack(const BrickBatch<T>& b, const std::vector<std::vector<T>>& bricks) {
    std::vector<T> host = b.makeHost();
    const Dims d = b.brick();
    for (std::size_t c = 0; c < bricks.size(); ++c)
        for (std::size_t z = 0; z < d.z; ++z)
            for (std::size_t y = 0; y < d.y; ++y)
                for (std::size_t x = 0; x < d.x; ++x)
                    host[c * b.brickStride() + (z * d.y + y) * b.pitch() + x] =
                        bricks[c][(z * d.y + y) * d.x + x];
    return host;
}
template <class T>
std::vector<T> unpackBrick(const BrickBatch<T>& b, const std::vector<T>& host, std::size_t c) {
    const Dims d = b.brick();
    std::vector<T> out(d.count());
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x)
                out[(z * d.y + y) * d.x + x] = host[c * b.brickStride() + (z * d.y + y) * b.pitch() + x];
    return out;
}

struct Case {
    Dims dims;
    int levels;
};
const Case kCases[] = {{{1, 1, 1}, 3},    {{1, 13, 1}, 3},  {{2, 3, 5}, 2},   {{7, 1, 1}, 2},
                       {{17, 19, 23}, 3}, {{31, 2, 3}, 4},  {{64, 64, 8}, 4}, {{97, 5, 11}, 3},
                       {{67, 33, 17}, 5}, {{40, 41, 43}, 3}};

} // namespace

TEST(WaveletReference, IntegerLiftingIsExactForEveryLength) {
    for (Wavelet w : kIntegerWavelets) {
        for (int n = 1; n <= 70; ++n) {
            auto x = randomInts(n, -40000, 70000, 7 + n);
            auto y = x;
            reference::forward1d(std::span<std::int32_t>(y), w);
            reference::inverse1d(std::span<std::int32_t>(y), w);
            ASSERT_EQ(x, y) << waveletName(w) << " n=" << n;
        }
    }
}

TEST(WaveletReference, FloatLiftingReconstructs) {
    for (Wavelet w : kAllWavelets) {
        for (int n = 1; n <= 70; ++n) {
            std::vector<double> x(n);
            for (int i = 0; i < n; ++i)
                x[i] = std::sin(0.37 * i) * 100 + (i % 3);
            auto y = x;
            reference::forward1d(std::span<double>(y), w);
            reference::inverse1d(std::span<double>(y), w);
            for (int i = 0; i < n; ++i)
                ASSERT_NEAR(x[i], y[i], 1e-9) << waveletName(w) << " n=" << n;
        }
    }
}

TEST(WaveletReference, LowBandHasUnitDcGainAndZeroDetail) {
    for (Wavelet w : kAllWavelets) {
        std::vector<double> x(37, 42.0);
        reference::forward1d(std::span<double>(x), w);
        for (int i = 0; i < 19; ++i)
            EXPECT_NEAR(x[i], 42.0, 1e-6) << waveletName(w);
        for (int i = 19; i < 37; ++i)
            EXPECT_NEAR(x[i], 0.0, 1e-6) << waveletName(w);
    }
}

TEST(WaveletReference, CoefficientsOfExtreme16BitDataFitInt32) {
    // 0/65535 checkerboard: the worst case for detail growth through several levels.
    const Dims d{33, 34, 35};
    std::vector<std::int32_t> v(d.count());
    for (std::size_t i = 0; i < v.size(); ++i)
        v[i] = ((i + i / d.x + i / (d.x * d.y)) & 1) ? 65535 : 0;
    for (Wavelet w : kIntegerWavelets) {
        auto c = v;
        reference::forward3d(std::span<std::int32_t>(c), d, 5, w);
        const auto [lo, hi] = std::minmax_element(c.begin(), c.end());
        EXPECT_LT(std::max(-std::int64_t(*lo), std::int64_t(*hi)), std::int64_t(1) << 20) << waveletName(w);
        reference::inverse3d(std::span<std::int32_t>(c), d, 5, w);
        EXPECT_EQ(c, v) << waveletName(w);
    }
}

TEST(WaveletKernels, IntegerKernelsMatchReferenceBitExactly) {
    ComputeContext& cc = test::computeContext();
    for (LiftingPath path : kPaths)
        for (Wavelet w : kIntegerWavelets) {
            LiftingTransform<std::int32_t> t(cc, w);
            t.setPath(path);
            for (const Case& cs : kCases) {
                const std::size_t count = 3;
                std::vector<std::vector<std::int32_t>> bricks;
                for (std::size_t c = 0; c < count; ++c)
                    bricks.push_back(randomInts(cs.dims.count(), c == 1 ? 0 : -32768, c == 1 ? 65535 : 32767,
                                                unsigned(c)));
                BrickBatch<std::int32_t> batch(cc, cs.dims, count);
                auto host = pack(batch, bricks);
                batch.upload(cc, host);
                t.forward(cc, batch, cs.levels);
                batch.download(cc, host);
                for (std::size_t c = 0; c < count; ++c) {
                    auto ref = bricks[c];
                    reference::forward3d(std::span<std::int32_t>(ref), cs.dims, cs.levels, w);
                    ASSERT_EQ(unpackBrick(batch, host, c), ref)
                        << pathName(path) << " " << waveletName(w) << " dims " << cs.dims.x << "x"
                        << cs.dims.y << "x" << cs.dims.z << " brick " << c;
                }
                t.inverse(cc, batch, cs.levels);
                batch.download(cc, host);
                for (std::size_t c = 0; c < count; ++c)
                    ASSERT_EQ(unpackBrick(batch, host, c), bricks[c])
                        << pathName(path) << " " << waveletName(w);
            }
        }
}

// The x pass blends partial vectors into memory; where a brick's last row ends closer than 16 elements before
// its pitch does, a blend would rewrite the next brick's first elements with the values it read, losing
// whatever the work-item transforming that brick stored meanwhile. Many small bricks whose rows end like
// that, transformed concurrently (PoCL's workers are pinned to different cores) and repeatedly: a race
// shows as a brick that differs from the reference.
TEST(WaveletKernels, ConcurrentBricksNeverTouchTheirNeighbours) {
    ComputeContext& cc = test::computeContext();
    LiftingTransform<std::int32_t> t(cc, Wavelet::Cdf53);
    t.setPath(LiftingPath::BrickResident);
    for (const Dims d : {Dims{15, 4, 3}, Dims{8, 3, 2}, Dims{40, 2, 3}}) {
        const std::size_t count = 256;
        std::vector<std::vector<std::int32_t>> bricks, refs;
        for (std::size_t c = 0; c < count; ++c) {
            bricks.push_back(randomInts(d.count(), -32768, 32767, unsigned(c)));
            refs.push_back(bricks.back());
            reference::forward3d(std::span<std::int32_t>(refs.back()), d, 2, Wavelet::Cdf53);
        }
        BrickBatch<std::int32_t> batch(cc, d, count);
        std::vector<std::int32_t> host = pack(batch, bricks);
        for (int rep = 0; rep < 20; ++rep) {
            batch.upload(cc, host);
            t.forward(cc, batch, 2);
            std::vector<std::int32_t> out = batch.makeHost();
            batch.download(cc, out);
            for (std::size_t c = 0; c < count; ++c)
                ASSERT_EQ(unpackBrick(batch, out, c), refs[c])
                    << d.x << "x" << d.y << "x" << d.z << " brick " << c << " forward, repetition " << rep;
            t.inverse(cc, batch, 2);
            batch.download(cc, out);
            for (std::size_t c = 0; c < count; ++c)
                ASSERT_EQ(unpackBrick(batch, out, c), bricks[c])
                    << d.x << "x" << d.y << "x" << d.z << " brick " << c << " inverse, repetition " << rep;
        }
    }
}

TEST(WaveletKernels, FloatKernelsMatchDoubleReference) {
    ComputeContext& cc = test::computeContext();
    for (LiftingPath path : kPaths)
        for (Wavelet w : kAllWavelets) {
            LiftingTransform<float> t(cc, w);
            t.setPath(path);
            for (const Case& cs : kCases) {
                std::vector<double> src(cs.dims.count());
                std::mt19937 rng(3);
                std::normal_distribution<double> noise(0, 5);
                for (std::size_t i = 0; i < src.size(); ++i)
                    src[i] = 1000 * std::sin(0.01 * double(i)) + noise(rng);
                std::vector<float> f(src.begin(), src.end());
                BrickBatch<float> batch(cc, cs.dims, 1);
                auto host = pack(batch, {f});
                batch.upload(cc, host);
                t.forward(cc, batch, cs.levels);
                batch.download(cc, host);
                auto ref = std::vector<double>(f.begin(), f.end());
                reference::forward3d(std::span<double>(ref), cs.dims, cs.levels, w);
                auto got = unpackBrick(batch, host, 0);
                double maxErr = 0;
                for (std::size_t i = 0; i < ref.size(); ++i)
                    maxErr = std::max(maxErr, std::abs(ref[i] - double(got[i])));
                // float32 rounding through up to 5 levels of 4 lifting steps on values of magnitude ~1e3
                EXPECT_LT(maxErr, 2e-3) << pathName(path) << " " << waveletName(w) << " " << cs.dims.x << "x"
                                        << cs.dims.y << "x" << cs.dims.z;
                t.inverse(cc, batch, cs.levels);
                batch.download(cc, host);
                got = unpackBrick(batch, host, 0);
                maxErr = 0;
                for (std::size_t i = 0; i < src.size(); ++i)
                    maxErr = std::max(maxErr, std::abs(double(f[i]) - got[i]));
                EXPECT_LT(maxErr, 2e-3) << pathName(path) << " " << waveletName(w);
            }
        }
}

TEST(WaveletKernels, EveryRowLengthMatchesTheReference) {
    // The brick kernel lifts rows of up to 64 samples as vectors of 16 (a half of up to 32 samples in two
    // vectors, partial vectors blended into memory, unaligned loads past the row end); every length from 1
    // to 66 (past the row path too), through 3 levels, with the last row ending the buffer.
    ComputeContext& cc = test::computeContext();
    LiftingTransform<std::int32_t> ti(cc, Wavelet::Cdf53);
    LiftingTransform<float> tf(cc, Wavelet::Cdf97);
    ti.setPath(LiftingPath::BrickResident);
    tf.setPath(LiftingPath::BrickResident);
    for (std::size_t n = 1; n <= 66; ++n) {
        const Dims d{n, 3, 2};
        const auto v = randomInts(d.count(), -32768, 65535, unsigned(n));
        BrickBatch<std::int32_t> bi(cc, d, 2);
        auto host = pack(bi, {v, v});
        bi.upload(cc, host);
        ti.forward(cc, bi, 3);
        bi.download(cc, host);
        auto ref = v;
        reference::forward3d(std::span<std::int32_t>(ref), d, 3, Wavelet::Cdf53);
        ASSERT_EQ(unpackBrick(bi, host, 1), ref) << "cdf53 n=" << n;
        ti.inverse(cc, bi, 3);
        bi.download(cc, host);
        ASSERT_EQ(unpackBrick(bi, host, 1), v) << "cdf53 inverse n=" << n;

        std::vector<float> f(v.begin(), v.end());
        BrickBatch<float> bf(cc, d, 1);
        auto hf = pack(bf, {f});
        bf.upload(cc, hf);
        tf.forward(cc, bf, 3);
        bf.download(cc, hf);
        std::vector<double> refd(v.begin(), v.end());
        reference::forward3d(std::span<double>(refd), d, 3, Wavelet::Cdf97);
        auto got = unpackBrick(bf, hf, 0);
        for (std::size_t i = 0; i < refd.size(); ++i)
            ASSERT_NEAR(got[i], refd[i], 0.05) << "cdf97 n=" << n << " i=" << i;
        tf.inverse(cc, bf, 3);
        bf.download(cc, hf);
        got = unpackBrick(bf, hf, 0);
        for (std::size_t i = 0; i < f.size(); ++i)
            ASSERT_NEAR(got[i], f[i], 0.05) << "cdf97 inverse n=" << n << " i=" << i;
    }
}

TEST(WaveletKernels, SeveralShapesInOneCallMatchTheReference) {
    // The codec transforms all of a volume's brick shapes in one call: one launch of the brick kernel per 8
    // batches (here 10 shapes on that path, so two launches, bricks handed out largest first), and a batch
    // too large for it (300 voxels along x) on the streaming passes in the same call.
    ComputeContext& cc = test::computeContext();
    const Dims shapes[] = {{17, 19, 23}, {1, 1, 1},   {2, 3, 5}, {40, 41, 43}, {7, 1, 1},   {300, 3, 2},
                           {31, 2, 3},   {64, 64, 8}, {3, 5, 2}, {9, 9, 9},    {64, 24, 52}};
    for (Wavelet w : {Wavelet::Cdf53, Wavelet::Cdf26}) {
        LiftingTransform<std::int32_t> t(cc, w);
        std::vector<std::unique_ptr<BrickBatch<std::int32_t>>> batches;
        std::vector<BrickBatch<std::int32_t>*> ptrs;
        std::vector<std::vector<std::vector<std::int32_t>>> bricks;
        for (std::size_t i = 0; i < std::size(shapes); ++i) {
            const std::size_t count = 1 + i % 3;
            bricks.emplace_back();
            for (std::size_t c = 0; c < count; ++c)
                bricks.back().push_back(randomInts(shapes[i].count(), -32768, 65535, unsigned(10 * i + c)));
            batches.push_back(std::make_unique<BrickBatch<std::int32_t>>(cc, shapes[i], count));
            ptrs.push_back(batches.back().get());
            batches.back()->upload(cc, pack(*batches.back(), bricks.back()));
        }
        t.forward(cc, std::span<BrickBatch<std::int32_t>* const>(ptrs), 3);
        for (std::size_t i = 0; i < batches.size(); ++i) {
            auto host = batches[i]->makeHost();
            batches[i]->download(cc, host);
            for (std::size_t c = 0; c < bricks[i].size(); ++c) {
                auto ref = bricks[i][c];
                reference::forward3d(std::span<std::int32_t>(ref), shapes[i], 3, w);
                ASSERT_EQ(unpackBrick(*batches[i], host, c), ref)
                    << waveletName(w) << " shape " << i << " brick " << c;
            }
        }
        t.inverse(cc, std::span<BrickBatch<std::int32_t>* const>(ptrs), 3, 1);
        t.inverse(cc, std::span<BrickBatch<std::int32_t>* const>(ptrs), 1);
        for (std::size_t i = 0; i < batches.size(); ++i) {
            auto host = batches[i]->makeHost();
            batches[i]->download(cc, host);
            for (std::size_t c = 0; c < bricks[i].size(); ++c)
                ASSERT_EQ(unpackBrick(*batches[i], host, c), bricks[i][c])
                    << waveletName(w) << " inverse shape " << i << " brick " << c;
        }
    }
}

TEST(WaveletKernels, PartialInverseGivesTheLevelApproximation) {
    ComputeContext& cc = test::computeContext();
    const Dims d{45, 38, 29};
    auto v = randomInts(d.count(), 0, 4095, 11);
    for (LiftingPath path : kPaths) {
        LiftingTransform<std::int32_t> t(cc, Wavelet::Cdf53);
        t.setPath(path);
        BrickBatch<std::int32_t> batch(cc, d, 1);
        auto host = pack(batch, {v});
        batch.upload(cc, host);
        t.forward(cc, batch, 4);
        t.inverse(cc, batch, 4, 2);
        batch.download(cc, host);
        auto got = unpackBrick(batch, host, 0);
        auto ref = v;
        reference::forward3d(std::span<std::int32_t>(ref), d, 2, Wavelet::Cdf53);
        const Dims l2 = levelDims(d, 2);
        for (std::size_t z = 0; z < l2.z; ++z)
            for (std::size_t y = 0; y < l2.y; ++y)
                for (std::size_t x = 0; x < l2.x; ++x) {
                    const std::size_t i = (z * d.y + y) * d.x + x;
                    ASSERT_EQ(got[i], ref[i]) << pathName(path) << " " << x << "," << y << "," << z;
                }
    }
}

TEST(WaveletKernels, MappedBatchesRoundTripExtremeDataThroughTheVectorPaths) {
    // 0/65535 checkerboards and full-range noise on 64- and 96-wide bricks (every x chunk of 16 pairs on the
    // aligned vector path, several chunks per row in the y/z passes), written and read through the mapped
    // host view the codec uses.
    ComputeContext& cc = test::computeContext();
    for (const Dims d : {Dims{64, 64, 16}, Dims{96, 32, 33}}) {
        std::vector<std::vector<std::int32_t>> bricks{std::vector<std::int32_t>(d.count()),
                                                      randomInts(d.count(), 0, 65535, 5)};
        for (std::size_t i = 0; i < d.count(); ++i)
            bricks[0][i] = ((i + i / d.x + i / (d.x * d.y)) & 1) ? 65535 : 0;
        for (LiftingPath path : kPaths)
            for (Wavelet w : kIntegerWavelets) {
                LiftingTransform<std::int32_t> t(cc, w);
                t.setPath(path);
                BrickBatch<std::int32_t> batch(cc, d, bricks.size());
                const auto host = pack(batch, bricks);
                {
                    BatchMapping<std::int32_t> m = batch.mapForWrite(cc);
                    ASSERT_EQ(m.span().size(), host.size());
                    std::copy(host.begin(), host.end(), m.data());
                }
                auto readBack = [&] {
                    BatchMapping<std::int32_t> m = batch.mapForRead(cc);
                    return std::vector<std::int32_t>(m.span().begin(), m.span().end());
                };
                t.forward(cc, batch, 4);
                const auto coeffs = readBack();
                for (std::size_t c = 0; c < bricks.size(); ++c) {
                    auto ref = bricks[c];
                    reference::forward3d(std::span<std::int32_t>(ref), d, 4, w);
                    ASSERT_EQ(unpackBrick(batch, coeffs, c), ref)
                        << pathName(path) << " " << waveletName(w) << " " << d.x << " brick " << c;
                }
                t.inverse(cc, batch, 4);
                const auto back = readBack();
                for (std::size_t c = 0; c < bricks.size(); ++c)
                    ASSERT_EQ(unpackBrick(batch, back, c), bricks[c])
                        << pathName(path) << " " << waveletName(w) << " " << d.x;
            }
    }
}

TEST(WaveletKernels, PathsAgreeAndAutoFallsBackForLargeBricks) {
    // Auto takes the brick-resident kernel on CPU devices up to kBrickResidentMaxDim and the streaming passes
    // beyond; the two paths give identical integer coefficients, so one path's forward inverts with the
    // other's inverse, also for bricks whose longest axis needs the largest LIFT_MAXN (256) and for a
    // 300-voxel axis (streaming only).
    ComputeContext& cc = test::computeContext();
    LiftingTransform<std::int32_t> a(cc, Wavelet::Cdf53), s(cc, Wavelet::Cdf53), b(cc, Wavelet::Cdf53);
    s.setPath(LiftingPath::Streaming);
    b.setPath(LiftingPath::BrickResident);
    for (const Dims d : {Dims{256, 7, 5}, Dims{3, 200, 9}, Dims{300, 3, 2}}) {
        const bool fits = std::max({d.x, d.y, d.z}) <= LiftingTransform<std::int32_t>::kBrickResidentMaxDim;
        BrickBatch<std::int32_t> batch(cc, d, 2);
        EXPECT_EQ(a.pathFor(batch),
                  fits && cc.device().isCpu ? LiftingPath::BrickResident : LiftingPath::Streaming);
        const std::vector<std::vector<std::int32_t>> bricks{randomInts(d.count(), 0, 65535, 21),
                                                            randomInts(d.count(), -32768, 32767, 22)};
        auto host = pack(batch, bricks);
        batch.upload(cc, host);
        (fits ? b : s).forward(cc, batch, 4);
        batch.download(cc, host);
        for (std::size_t c = 0; c < bricks.size(); ++c) {
            auto ref = bricks[c];
            reference::forward3d(std::span<std::int32_t>(ref), d, 4, Wavelet::Cdf53);
            ASSERT_EQ(unpackBrick(batch, host, c), ref) << d.x << "x" << d.y << "x" << d.z;
        }
        a.inverse(cc, batch, 4);
        batch.download(cc, host);
        for (std::size_t c = 0; c < bricks.size(); ++c)
            ASSERT_EQ(unpackBrick(batch, host, c), bricks[c]) << d.x << "x" << d.y << "x" << d.z;
    }
}

// forwardFromVoxels reads each brick's voxels in the kernel: it must give the same coefficients as a batch
// the host filled, and each brick's voxel range; inverseToVoxels writes voxels as the host would convert
// them (round to nearest even, clamp to the type). Bricks of 7 shapes (edges of a 32-voxel grid) in one
// call, a volume with a saturated slab so the lossy reconstruction leaves the type's range.
TEST(WaveletKernels, VoxelVolumesInAndOutMatchHostGatherAndPlacement) {
    ComputeContext& cc = test::computeContext();
    const Dims dims{70, 45, 33}, grid{32, 32, 32};
    struct Run {
        ScalarType type;
        Wavelet w;
    };
    auto check = [&]<class T>(LiftingTransform<T>& t, const Volume& v) {
        // Bricks grouped by shape, as the codec does.
        std::map<std::tuple<std::size_t, std::size_t, std::size_t>, std::vector<Dims>> groups;
        for (std::size_t z = 0; z < dims.z; z += grid.z)
            for (std::size_t y = 0; y < dims.y; y += grid.y)
                for (std::size_t x = 0; x < dims.x; x += grid.x)
                    groups[{std::min(grid.x, dims.x - x), std::min(grid.y, dims.y - y),
                            std::min(grid.z, dims.z - z)}]
                        .push_back({x, y, z});
        std::vector<std::unique_ptr<BrickBatch<T>>> host, kernel;
        std::vector<BrickBatch<T>*> hostPtrs, kernelPtrs;
        VoxelVolume in{
            cc.wrapHost(const_cast<Volume&>(v).bytes(), CL_MEM_READ_ONLY).get(), v.type(), dims, {}};
        std::vector<std::vector<std::pair<double, double>>> wantRanges;
        for (const auto& [shape, origins] : groups) {
            const Dims s{std::get<0>(shape), std::get<1>(shape), std::get<2>(shape)};
            host.push_back(std::make_unique<BrickBatch<T>>(cc, s, origins.size()));
            kernel.push_back(std::make_unique<BrickBatch<T>>(cc, s, origins.size()));
            hostPtrs.push_back(host.back().get());
            kernelPtrs.push_back(kernel.back().get());
            std::vector<std::vector<T>> bricks;
            auto& ranges = wantRanges.emplace_back();
            for (const Dims& o : origins) {
                auto& b = bricks.emplace_back();
                for (std::size_t z = 0; z < s.z; ++z)
                    for (std::size_t y = 0; y < s.y; ++y)
                        for (std::size_t x = 0; x < s.x; ++x)
                            b.push_back(static_cast<T>(v.valueAt(v.index(o.x + x, o.y + y, o.z + z))));
                const auto [lo, hi] = std::minmax_element(b.begin(), b.end());
                ranges.push_back({double(*lo), double(*hi)});
            }
            host.back()->upload(cc, pack(*host.back(), bricks));
            in.origins.push_back(origins);
        }
        ASSERT_TRUE(t.canUseVoxels(kernelPtrs));
        t.forward(cc, std::span<BrickBatch<T>* const>(hostPtrs), 3);
        std::vector<std::vector<std::pair<double, double>>> ranges;
        t.forwardFromVoxels(cc, std::span<BrickBatch<T>* const>(kernelPtrs), 3, in, &ranges);
        EXPECT_EQ(ranges, wantRanges);
        for (std::size_t k = 0; k < host.size(); ++k) {
            auto a = host[k]->makeHost(), b = kernel[k]->makeHost();
            host[k]->download(cc, a);
            kernel[k]->download(cc, b);
            for (std::size_t c = 0; c < host[k]->count(); ++c)
                ASSERT_EQ(unpackBrick(*host[k], a, c), unpackBrick(*kernel[k], b, c))
                    << "forward batch " << k;
        }
        // Floats: zero every third coefficient of both batches alike, so that the reconstruction needs
        // rounding and overshoots the type's range next to the slab (integers stay exact).
        if constexpr (std::is_same_v<T, float>)
            for (std::size_t k = 0; k < host.size(); ++k) {
                auto a = host[k]->makeHost();
                host[k]->download(cc, a);
                for (std::size_t i = 0; i < a.size(); i += 3)
                    a[i] = 0;
                host[k]->upload(cc, a);
                kernel[k]->upload(cc, a);
            }
        Volume out(dims, v.type());
        VoxelVolume target{cc.wrapHost(out.bytes()).get(), v.type(), dims, in.origins};
        t.inverse(cc, std::span<BrickBatch<T>* const>(hostPtrs), 3);
        t.inverseToVoxels(cc, std::span<BrickBatch<T>* const>(kernelPtrs), 3, target);
        BatchMapping<std::uint8_t> m(cc.queue(), target.voxels, out.bytes().size(), CL_MAP_READ);
        std::size_t k = 0;
        for (const auto& [shape, origins] : groups) {
            auto a = host[k]->makeHost();
            host[k]->download(cc, a);
            for (std::size_t c = 0; c < origins.size(); ++c) {
                const auto rec = unpackBrick(*host[k], a, c);
                const Dims s = host[k]->brick(), o = origins[c];
                for (std::size_t i = 0; i < rec.size(); ++i) {
                    const std::size_t x = i % s.x, y = i / s.x % s.y, z = i / (s.x * s.y);
                    const Volume one = [&] {
                        Volume f({1, 1, 1}, ScalarType::Float32);
                        f.values<float>()[0] = static_cast<float>(rec[i]);
                        return f.convertedTo(v.type());
                    }();
                    ASSERT_EQ(out.valueAt(out.index(o.x + x, o.y + y, o.z + z)), one.valueAt(0))
                        << "brick " << c << " of shape " << k << " voxel " << i;
                }
            }
            ++k;
        }
    };
    Volume u8(dims, ScalarType::UInt8), i16(dims, ScalarType::Int16), f32(dims, ScalarType::Float32);
    std::mt19937 rng(5);
    for (std::size_t i = 0; i < dims.count(); ++i) {
        const bool slab = i % dims.x < 9;
        u8.values<std::uint8_t>()[i] = slab ? 255 : std::uint8_t(rng() % 200);
        i16.values<std::int16_t>()[i] = slab ? -32768 : std::int16_t(rng() % 60000 - 30000);
        f32.values<float>()[i] = slab ? 1e6f : float(rng() % 1000) * 0.37f;
    }
    LiftingTransform<float> f97(cc, Wavelet::Cdf97), haar(cc, Wavelet::Haar);
    LiftingTransform<std::int32_t> i53(cc, Wavelet::Cdf53);
    check(f97, u8);
    check(haar, f32);
    check(i53, i16);
    check(i53, u8);
}
