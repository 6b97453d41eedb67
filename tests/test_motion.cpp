// Motion estimation: the OpenCL block search against the C++ reference (exact), known shifts found,
// hard cases (partial blocks, motion beyond the radius, constant frames, noise), real series.
#include "TestUtil.hpp"
#include "core/Error.hpp"
#include "host/io/VolumeIo.hpp"
#include "wavelet/predict/MotionSearch.hpp"
#include "wavelet/predict/TranslatedSeries.hpp"

#include <zlib.h>

#include <cmath>
#include <random>

using namespace volcl;
namespace fs = std::filesystem;

namespace {

// A smooth field without a direction along which it is constant (no aperture problem): Gaussian blobs
// of several widths at fixed pseudo-random places, on a gentle gradient.
double smoothField(double x, double y, double z) {
    struct Blob {
        double x, y, z, r2, a;
    };
    static const std::vector<Blob> blobs = [] {
        std::mt19937 rng(11);
        std::uniform_real_distribution<double> pos(-4, 52), rad(2.0, 4.5), amp(-700, 900);
        std::vector<Blob> b;
        for (int i = 0; i < 90; ++i) {
            const double r = rad(rng);
            b.push_back({pos(rng), pos(rng), pos(rng), 2 * r * r, amp(rng)});
        }
        return b;
    }();
    double v = 4000 + 3 * x - 2 * y + z;
    for (const Blob& b : blobs)
        v += b.a * std::exp(-((x - b.x) * (x - b.x) + (y - b.y) * (y - b.y) + (z - b.z) * (z - b.z)) / b.r2);
    return v;
}

// uint16 volume of 2 * round(f(x - s)) (even values, so half-voxel means of two voxels are integers).
Volume evenVolume(Dims d, std::array<double, 3> s) {
    Volume v(d, ScalarType::UInt16);
    auto vals = v.values<std::uint16_t>();
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x)
                vals[v.index(x, y, z)] = static_cast<std::uint16_t>(
                    2 * std::lround(smoothField(double(x) - s[0], double(y) - s[1], double(z) - s[2])));
    return v;
}

// `ref` resampled at p + v (whole voxels), clamp-to-edge: the frame whose true vector is v everywhere.
Volume movedBy(const Volume& ref, int vx, int vy, int vz) {
    Volume out(ref.dims(), ref.type());
    const Dims d = ref.dims();
    auto in = ref.values<std::uint16_t>();
    auto o = out.values<std::uint16_t>();
    auto c = [](long v, std::size_t n) { return std::size_t(std::clamp<long>(v, 0, long(n) - 1)); };
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x)
                o[out.index(x, y, z)] =
                    in[ref.index(c(long(x) + vx, d.x), c(long(y) + vy, d.y), c(long(z) + vz, d.z))];
    return out;
}

Volume noiseVolume(Dims d, unsigned seed, int range = 4096) {
    Volume v(d, ScalarType::UInt16);
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> u(0, range - 1);
    for (auto& x : v.values<std::uint16_t>())
        x = static_cast<std::uint16_t>(u(rng));
    return v;
}

// The kernel and the reference agree on every block's vector and cost.
MotionSearchResult expectKernelMatchesReference(const Volume& cur, const Volume& ref,
                                                const MotionSearchOptions& o) {
    ComputeContext& cc = test::computeContext();
    MotionEstimator est(cc, o);
    const int levels = o.method == MotionSearchMethod::Hierarchical ? hierarchyLevels(o) : 0;
    const MotionSearchSamples s = prepareSearchSamples(cur, ref, levels);
    const MotionSearchResult k = est.search(cc, s);
    const MotionSearchResult r = searchMotionReference(s, o);
    EXPECT_EQ(k.grid, r.grid);
    EXPECT_EQ(k.vectors.size(), r.vectors.size());
    std::size_t vectorDiff = 0, costDiff = 0;
    for (std::size_t b = 0; b < std::min(k.vectors.size(), r.vectors.size()); ++b) {
        vectorDiff += !(k.vectors[b] == r.vectors[b]);
        costDiff += k.costs[b] != r.costs[b];
    }
    EXPECT_EQ(vectorDiff, 0u) << "blocks whose kernel vector differs from the reference";
    EXPECT_EQ(costDiff, 0u) << "blocks whose kernel cost differs from the reference";
    return r;
}

std::vector<MotionSearchOptions> optionGrid(std::size_t block, int radius) {
    std::vector<MotionSearchOptions> out;
    for (MotionSearchMethod m : {MotionSearchMethod::Full, MotionSearchMethod::Hierarchical})
        for (MotionCost c : {MotionCost::Sad, MotionCost::Ssd})
            out.push_back({block, radius, m, c, true});
    return out;
}

bool interiorBlock(const BlockGrid& g, std::size_t b, std::size_t margin) {
    const Dims nb = g.blocks();
    const std::size_t x = b % nb.x, y = (b / nb.x) % nb.y, z = b / (nb.x * nb.y);
    auto in = [&](std::size_t i, std::size_t n, std::size_t dim) {
        return i * g.size >= margin && (i + 1) * g.size + margin <= dim;
    };
    return in(x, nb.x, g.volume.x) && in(y, nb.y, g.volume.y) && in(z, nb.z, g.volume.z);
}

// The full search finds a known whole-voxel vector in every interior block; the hierarchical search
// refines by one voxel per level, so a coarse level that rounds a sub-voxel motion the wrong way can
// leave a block one voxel off (a local minimum): it must still find half of them.
void expectFound(const MotionSearchOptions& o, std::size_t found, std::size_t interior) {
    if (o.method == MotionSearchMethod::Full)
        EXPECT_EQ(found, interior) << "full search, cost " << int(o.cost);
    else
        EXPECT_GE(found * 2, interior)
            << found << " of " << interior << ", hierarchical, cost " << int(o.cost);
}

Volume readGzipRaw(const fs::path& p, Dims d) {
    Volume v(d, ScalarType::UInt8);
    gzFile f = gzopen(p.string().c_str(), "rb");
    EXPECT_NE(f, nullptr);
    const int n = gzread(f, v.bytes().data(), static_cast<unsigned>(v.byteSize()));
    gzclose(f);
    EXPECT_EQ(n, int(v.byteSize()));
    return v;
}

} // namespace

TEST(MotionSearch, OptionsAreValidated) {
    EXPECT_THROW(validate(MotionSearchOptions{.blockSize = 6}), UsageError);
    EXPECT_THROW(validate(MotionSearchOptions{.blockSize = 64}), UsageError);
    EXPECT_THROW(validate(MotionSearchOptions{.radius = 16}), UsageError);
    EXPECT_THROW(validate(MotionSearchOptions{.radius = -1}), UsageError);
    EXPECT_NO_THROW(validate(MotionSearchOptions{.blockSize = 4, .radius = 0}));
    EXPECT_EQ(hierarchyLevels({.blockSize = 8, .radius = 8}), 2);
    EXPECT_EQ(hierarchyLevels({.blockSize = 4, .radius = 8}), 1);
    EXPECT_EQ(hierarchyLevels({.blockSize = 8, .radius = 1}), 0);
}

TEST(MotionSearch, KnownIntegerShiftIsFoundExactlyOnPartialBlocks) {
    const Dims d{37, 30, 27}; // no dimension a multiple of 8
    const Volume ref = evenVolume(d, {0, 0, 0});
    const Volume cur = movedBy(ref, 2, -1, 3);
    for (const MotionSearchOptions& o : optionGrid(8, 4)) {
        const MotionSearchResult r = expectKernelMatchesReference(cur, ref, o);
        std::size_t interior = 0, found = 0;
        for (std::size_t b = 0; b < r.vectors.size(); ++b) {
            if (!interiorBlock(r.grid, b, 4)) continue;
            ++interior;
            found += r.vectors[b] == MotionVector{4, -2, 6} && r.costs[b] == 0;
        }
        EXPECT_GT(interior, 0u);
        expectFound(o, found, interior);
    }
}

TEST(MotionSearch, KnownHalfVoxelShiftIsFoundExactly) {
    const Dims d{40, 32, 24};
    const Volume ref = evenVolume(d, {0, 0, 0});
    // cur(p) = mean of ref(p) and ref(p + x) = the trilinear sample at p + (1/2, 0, 0); then moved by (0, 1, 0).
    Volume cur(d, ScalarType::UInt16);
    {
        auto in = ref.values<std::uint16_t>();
        auto o = cur.values<std::uint16_t>();
        for (std::size_t z = 0; z < d.z; ++z)
            for (std::size_t y = 0; y < d.y; ++y)
                for (std::size_t x = 0; x < d.x; ++x) {
                    const std::size_t y1 = std::min(y + 1, d.y - 1), x1 = std::min(x + 1, d.x - 1);
                    o[cur.index(x, y, z)] =
                        static_cast<std::uint16_t>((in[ref.index(x, y1, z)] + in[ref.index(x1, y1, z)]) / 2);
                }
    }
    // The half-voxel step refines the best whole-voxel vector by +-1/2: wherever that vector is next to
    // the true one, the true one must be found exactly (cost 0); that must be most interior blocks.
    for (const MotionSearchOptions& o : optionGrid(8, 2)) {
        const MotionSearchResult r = expectKernelMatchesReference(cur, ref, o);
        MotionSearchOptions whole = o;
        whole.halfVoxel = false;
        const MotionSearchResult w = expectKernelMatchesReference(cur, ref, whole);
        std::size_t interior = 0, adjacent = 0;
        for (std::size_t b = 0; b < r.vectors.size(); ++b) {
            if (!interiorBlock(r.grid, b, 2)) continue;
            ++interior;
            const MotionVector v = w.vectors[b];
            if (std::abs(v.x - 1) > 1 || std::abs(v.y - 2) > 1 || std::abs(v.z) > 1) continue;
            ++adjacent;
            EXPECT_EQ(r.vectors[b], (MotionVector{1, 2, 0})) << "block " << b;
            EXPECT_EQ(r.costs[b], 0u) << "block " << b;
        }
        EXPECT_GE(adjacent * 2, interior) << adjacent << " of " << interior << ", method " << int(o.method);
    }
    // Without half-voxel refinement the vector stays on whole voxels.
    const MotionSearchResult whole =
        expectKernelMatchesReference(cur, ref, {8, 2, MotionSearchMethod::Full, MotionCost::Ssd, false});
    for (const MotionVector& v : whole.vectors)
        EXPECT_TRUE(v.x % 2 == 0 && v.y % 2 == 0 && v.z % 2 == 0);
}

TEST(MotionSearch, MotionBeyondTheRadiusGivesTheBestVectorInRange) {
    const Dims d{48, 40, 32};
    const Volume ref = evenVolume(d, {0, 0, 0});
    const Volume cur = movedBy(ref, 6, 0, -5);
    for (const MotionSearchOptions& o : optionGrid(8, 2)) {
        const MotionSearchResult r = expectKernelMatchesReference(cur, ref, o);
        const MotionSearchSamples s = prepareSearchSamples(cur, ref, 0);
        const MotionSearchResult zero =
            searchMotionReference(s, {8, 0, MotionSearchMethod::Full, o.cost, false});
        for (std::size_t b = 0; b < r.vectors.size(); ++b) {
            const MotionVector v = r.vectors[b];
            EXPECT_TRUE(std::abs(v.x) <= 4 && std::abs(v.y) <= 4 && std::abs(v.z) <= 4) << "block " << b;
            EXPECT_LE(r.costs[b], zero.costs[b]) << "block " << b << " worse than no motion";
        }
    }
}

TEST(MotionSearch, ConstantFramesGiveZeroVectors) {
    Volume a({20, 17, 9}, ScalarType::UInt16), b({20, 17, 9}, ScalarType::UInt16);
    std::fill(a.values<std::uint16_t>().begin(), a.values<std::uint16_t>().end(), 700);
    std::fill(b.values<std::uint16_t>().begin(), b.values<std::uint16_t>().end(), 65535);
    for (const MotionSearchOptions& o : optionGrid(8, 3)) {
        const MotionSearchResult same = expectKernelMatchesReference(a, a, o);
        const MotionSearchResult jump = expectKernelMatchesReference(b, a, o);
        for (std::size_t i = 0; i < same.vectors.size(); ++i) {
            EXPECT_EQ(same.vectors[i], MotionVector{});
            EXPECT_EQ(same.costs[i], 0u);
            EXPECT_EQ(jump.vectors[i], MotionVector{}) << "all costs equal: the tie-break picks zero";
        }
    }
    // Float frames that are constant map to one integer value too.
    Volume f({9, 9, 9}, ScalarType::Float32);
    std::fill(f.values<float>().begin(), f.values<float>().end(), 3.5f);
    const MotionSearchResult r = expectKernelMatchesReference(f, f, {4, 2});
    for (const MotionVector& v : r.vectors)
        EXPECT_EQ(v, MotionVector{});
}

TEST(MotionSearch, NoiseAndExtremeValuesAgreeExactly) {
    const Dims d{33, 19, 17};
    for (const MotionSearchOptions& o : optionGrid(8, 3))
        expectKernelMatchesReference(noiseVolume(d, 1), noiseVolume(d, 2), o);
    // Full 16-bit range alternating between frames: the SSD of 8^3 half-voxel samples stays exact in 64 bits.
    Volume lo(d, ScalarType::UInt16), hi(d, ScalarType::UInt16);
    auto h = hi.values<std::uint16_t>();
    for (std::size_t i = 0; i < h.size(); ++i)
        h[i] = (i % 2) ? 65535 : 0;
    expectKernelMatchesReference(hi, lo, {8, 2, MotionSearchMethod::Full, MotionCost::Ssd, true});
    Volume s16(d, ScalarType::Int16);
    auto sv = s16.values<std::int16_t>();
    for (std::size_t i = 0; i < sv.size(); ++i)
        sv[i] = (i % 3) ? -32768 : 32767;
    Volume s16b(d, ScalarType::Int16);
    auto sb = s16b.values<std::int16_t>();
    for (std::size_t i = 0; i < sb.size(); ++i)
        sb[i] = (i % 2) ? -32768 : 32767;
    expectKernelMatchesReference(s16, s16b, {4, 2, MotionSearchMethod::Hierarchical, MotionCost::Sad, true});
    // Block sizes 2..32 and a radius of zero.
    for (std::size_t bs : {2u, 4u, 16u, 32u})
        expectKernelMatchesReference(noiseVolume(d, 3), noiseVolume(d, 4),
                                     {bs, 2, MotionSearchMethod::Hierarchical, MotionCost::Ssd, true});
    expectKernelMatchesReference(noiseVolume(d, 3), noiseVolume(d, 4), {8, 0});
    // Degenerate volumes: one voxel, one line.
    expectKernelMatchesReference(noiseVolume({1, 1, 1}, 5), noiseVolume({1, 1, 1}, 6), {8, 3});
    expectKernelMatchesReference(noiseVolume({50, 1, 1}, 5), noiseVolume({50, 1, 1}, 6),
                                 {8, 3, MotionSearchMethod::Hierarchical});
}

TEST(MotionSearch, NanFramesAndMismatchedFramesAreRefused) {
    Volume a({8, 8, 8}, ScalarType::Float32), b({8, 8, 8}, ScalarType::Float32);
    b.values<float>()[17] = NAN;
    EXPECT_THROW(prepareSearchSamples(a, b, 0), DataError);
    EXPECT_THROW(prepareSearchSamples(a, Volume({8, 8, 7}, ScalarType::Float32), 0), DataError);
}

TEST(MotionSearch, ShiftedRealMriFindsTheNearestHalfVoxelVector) {
    fs::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const Volume mri = readGzipRaw(data / "regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz",
                                   {180, 216, 180});
    const Volume crop = mri.cropped({58, 76, 58}, {122, 140, 122}); // a 64^3 block of brain
    // Content moves by s per frame, so frame 1 at p matches frame 0 at p - s: the vector is -s.
    const TimeSeries ts = translatedSeries(crop, 2, {1.5, -1.0, 0.5});
    for (const MotionSearchOptions& o : optionGrid(8, 2)) {
        const MotionSearchResult r = expectKernelMatchesReference(ts.frames[1], ts.frames[0], o);
        // Cubic resampling is sharper than the search's trilinear half-voxel samples, so many blocks settle
        // one half voxel off the true vector (flat or noisy blocks further): half exact, 3/4 within 1/2 voxel.
        std::size_t interior = 0, exact = 0, near = 0;
        for (std::size_t b = 0; b < r.vectors.size(); ++b) {
            if (!interiorBlock(r.grid, b, 8)) continue;
            ++interior;
            const MotionVector v = r.vectors[b];
            exact += v == MotionVector{-3, 2, -1};
            near += std::abs(v.x + 3) <= 1 && std::abs(v.y - 2) <= 1 && std::abs(v.z + 1) <= 1;
        }
        EXPECT_GE(exact * 2, interior)
            << exact << " of " << interior << " interior blocks, method " << int(o.method);
        EXPECT_GE(near * 4, interior * 3)
            << near << " of " << interior << " interior blocks, method " << int(o.method);
    }
}

TEST(MotionSearch, RealSeriesAgreeExactly) {
    fs::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const fs::path vf = data / "timevarying/viscousfingers";
    const Volume a = readVolume(vf / "005_density_005_064_2.0.vti"),
                 b = readVolume(vf / "006_density_006_064_2.0.vti");
    expectKernelMatchesReference(b, a, {8, 2, MotionSearchMethod::Full, MotionCost::Ssd, true});
    expectKernelMatchesReference(b, a, {8, 4, MotionSearchMethod::Hierarchical, MotionCost::Sad, true});
    const fs::path is = data / "timevarying/isabel";
    // Isabel is float64; motion search works on float32 (series of float64 frames are I frames).
    const Volume i2 = readVolume(is / "isabel_02.vti").convertedTo(ScalarType::Float32),
                 i3 = readVolume(is / "isabel_03.vti").convertedTo(ScalarType::Float32);
    expectKernelMatchesReference(i3, i2, {8, 4, MotionSearchMethod::Hierarchical, MotionCost::Ssd, true});
}

TEST(TranslatedSeries, FrameZeroIsTheBaseAndWholeShiftsMoveContent) {
    const Volume base = evenVolume({20, 16, 12}, {0, 0, 0});
    const TimeSeries ts = translatedSeries(base, 3, {1, 0, -1});
    ASSERT_EQ(ts.frames.size(), 3u);
    EXPECT_EQ(ts.frames[0], base);
    // Frame 2 at p equals base at p - 2 s (away from the clamped faces).
    const auto f2 = ts.frames[2].values<std::uint16_t>();
    const auto b = base.values<std::uint16_t>();
    for (std::size_t z = 0; z < 10; ++z)
        for (std::size_t y = 0; y < 16; ++y)
            for (std::size_t x = 2; x < 20; ++x)
                ASSERT_EQ(f2[base.index(x, y, z)], b[base.index(x - 2, y, z + 2)]);
    EXPECT_THROW(translatedSeries(base, 0, {1, 0, 0}), UsageError);
    EXPECT_THROW(translatedSeries(base, 2, {NAN, 0, 0}), UsageError);
}
