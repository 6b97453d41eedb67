// Overlapped block motion compensation and motion-field coding: windows sum to 1, kernels against the
// double references, shifted volumes predicted without seams, mode decision, vector coding round trips.
#include "TestUtil.hpp"
#include "core/Error.hpp"
#include "wavelet/predict/Compensation.hpp"
#include "wavelet/predict/MotionSearch.hpp"
#include "wavelet/predict/MotionVectorCoding.hpp"
#include "wavelet/predict/Residual.hpp"
#include "wavelet/predict/TranslatedSeries.hpp"

#include <cmath>
#include <random>

using namespace volcl;

namespace {

Volume blobs(Dims d, unsigned seed = 5) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> px(0, double(d.x)), py(0, double(d.y)), pz(0, double(d.z)),
        rad(2.5, 5), amp(-50, 80);
    struct B {
        double x, y, z, r2, a;
    };
    std::vector<B> bs;
    for (int i = 0; i < 60; ++i) {
        const double r = rad(rng);
        bs.push_back({px(rng), py(rng), pz(rng), 2 * r * r, amp(rng)});
    }
    return test::makeFloatVolume(d, [&](double x, double y, double z) {
        double v = 100 + 0.5 * x;
        for (const B& b : bs)
            v += b.a *
                 std::exp(-((x - b.x) * (x - b.x) + (y - b.y) * (y - b.y) + (z - b.z) * (z - b.z)) / b.r2);
        return v;
    });
}

double range(const Volume& v) {
    const VolumeStats s = v.stats(1);
    return s.max - s.min;
}

double maxAbsDiff(const Volume& a, const Volume& b) {
    double m = 0;
    for (std::size_t i = 0; i < a.voxelCount(); ++i)
        m = std::max(m, std::abs(a.valueAt(i) - b.valueAt(i)));
    return m;
}

// Searched P-frame field and its prediction (kernel), checked against the references.
struct Prediction {
    MotionField field;
    Volume kernel, reference;
};

Prediction predictP(const Volume& cur, const Volume& ref, MotionSearchOptions o = {8, 3}) {
    ComputeContext& cc = test::computeContext();
    MotionEstimator est(cc, o);
    const MotionSearchResult r = est.search(cc, cur, ref);
    MotionCompensator comp(cc);
    std::vector<ModeCosts> kc, rc;
    Prediction p;
    p.field = comp.decideModes(cc, cur, ref, nullptr, r.grid, r.vectors, nullptr, {}, &kc);
    const MotionField rf = decideModesReference(cur, ref, nullptr, r.grid, r.vectors, nullptr, {}, &rc);
    for (std::size_t b = 0; b < kc.size(); ++b) {
        for (int m = 0; m < kBlockModeCount; ++m) {
            if (std::isinf(rc[b][m])) {
                EXPECT_TRUE(std::isinf(kc[b][m]));
                continue;
            }
            EXPECT_NEAR(kc[b][m], rc[b][m], 1e-4 * std::max(rc[b][m], 1e-3 * range(cur) * range(cur)))
                << "block " << b << " mode " << m;
        }
        EXPECT_NEAR(p.field.intraValue[b], rf.intraValue[b], 1e-5 * range(cur) + 1e-6);
        // Modes agree unless two costs are within the float tolerance.
        if (p.field.modes[b] != rf.modes[b]) {
            const double a = rc[b][int(p.field.modes[b])], c = rc[b][int(rf.modes[b])];
            EXPECT_NEAR(a, c, 1e-4 * std::max(a, c) + 1e-9) << "block " << b << " decided differently";
        }
    }
    p.kernel = comp.compensate(cc, p.field, ref, nullptr);
    p.reference = compensateReference(p.field, ref, nullptr);
    EXPECT_LE(maxAbsDiff(p.kernel, p.reference), 1e-5 * range(ref) + 1e-6);
    return p;
}

// Mean squared residual on voxels next to a block face (coordinate mod B in {0, B-1} along any axis)
// and on the others.
std::pair<double, double> boundaryAndInteriorEnergy(const Volume& cur, const Volume& pred, std::size_t B,
                                                    std::size_t margin) {
    double eb = 0, ei = 0;
    std::size_t nb = 0, ni = 0;
    const Dims d = cur.dims();
    for (std::size_t z = margin; z < d.z - margin; ++z)
        for (std::size_t y = margin; y < d.y - margin; ++y)
            for (std::size_t x = margin; x < d.x - margin; ++x) {
                const std::size_t i = cur.index(x, y, z);
                const double r = cur.valueAt(i) - pred.valueAt(i);
                auto face = [&](std::size_t c) { return c % B == 0 || c % B == B - 1; };
                if (face(x) || face(y) || face(z)) {
                    eb += r * r;
                    ++nb;
                } else {
                    ei += r * r;
                    ++ni;
                }
            }
    return {eb / double(nb), ei / double(ni)};
}

} // namespace

TEST(MotionWindows, RaisedCosineWindowsSumToOne) {
    // 8^3 blocks: 12-sample windows whose overlapping halves sum to 1.
    EXPECT_EQ(overlapFor(8), 2u);
    for (std::size_t B : {4u, 8u, 16u}) {
        const std::size_t o = overlapFor(B);
        for (std::size_t t = 0; t < 2 * o; ++t)
            EXPECT_NEAR(overlapWindow(B, o, t + B) + overlapWindow(B, o, t), 1.0, 1e-15) << B << " " << t;
        EXPECT_EQ(overlapWindow(B, o, B + 2 * o), 0.0);
        for (std::size_t t = 2 * o; t < B; ++t)
            EXPECT_EQ(overlapWindow(B, o, t), 1.0);
    }
    for (std::size_t B : {2u, 4u, 8u, 16u})
        for (std::size_t n : {1u, 3u, 8u, 13u, 33u, 64u}) {
            const AxisWeights a = axisWeights(n, B);
            const std::size_t nb = (n + B - 1) / B;
            for (std::size_t x = 0; x < n; ++x) {
                EXPECT_NEAR(a.w0[x] + a.w1[x], 1.0, 1e-15) << "n " << n << " B " << B << " x " << x;
                EXPECT_GE(a.first[x], 0);
                EXPECT_LT(std::size_t(a.first[x]) + (a.w1[x] > 0 ? 1 : 0), nb);
            }
        }
    // Separable: the 3D weights of a voxel sum to 1 as products of 1D sums; constant references
    // therefore predict the constant exactly whatever the modes and vectors.
    const Volume c = test::makeFloatVolume({21, 18, 11}, [](double, double, double) { return 42.5; });
    MotionField f;
    f.grid = {c.dims(), 8};
    const std::size_t n = f.grid.count();
    f.modes.assign(n, BlockMode::Forward);
    f.forward.assign(n, MotionVector{3, -5, 1});
    f.intraValue.assign(n, 42.5f);
    for (std::size_t b = 0; b < n; b += 3)
        f.modes[b] = b % 2 ? BlockMode::Intra : BlockMode::Zero;
    ComputeContext& cc = test::computeContext();
    MotionCompensator comp(cc);
    EXPECT_LE(maxAbsDiff(comp.compensate(cc, f, c, nullptr), c), 1e-5);
    EXPECT_LE(maxAbsDiff(compensateReference(f, c, nullptr), c), 1e-12);
}

TEST(MotionCompensation, ShiftedSmoothVolumeIsPredictedWithoutSeams) {
    const Volume base = blobs({45, 38, 29}); // no dimension a multiple of 8
    const TimeSeries ts = translatedSeries(base, 2, {1.3, -0.6, 0.8});
    const Prediction p = predictP(ts.frames[1], ts.frames[0]);
    const Volume& cur = ts.frames[1];
    // Small residual: against no motion, and in absolute terms.
    double e = 0, e0 = 0;
    for (std::size_t i = 0; i < cur.voxelCount(); ++i) {
        e += std::pow(cur.valueAt(i) - p.kernel.valueAt(i), 2);
        e0 += std::pow(cur.valueAt(i) - ts.frames[0].valueAt(i), 2);
    }
    const double rmse = std::sqrt(e / double(cur.voxelCount())),
                 rmse0 = std::sqrt(e0 / double(cur.voxelCount()));
    EXPECT_LT(rmse, 0.25 * rmse0) << "motion-compensated RMSE " << rmse << " against no motion " << rmse0;
    EXPECT_LT(rmse, 0.01 * range(cur));
    // No seams: the residual next to block faces is no larger than inside blocks.
    const auto [boundary, interior] = boundaryAndInteriorEnergy(cur, p.kernel, 8, 4);
    EXPECT_LE(boundary, 1.1 * interior) << "boundary " << boundary << " interior " << interior;
    std::size_t inter = 0;
    for (BlockMode m : p.field.modes)
        inter += m == BlockMode::Forward;
    EXPECT_GE(inter * 2, p.field.modes.size());
}

TEST(MotionCompensation, NoiseAfterASmoothFramePicksIntra) {
    const Dims d{32, 24, 20};
    const Volume smooth = blobs(d);
    std::mt19937 rng(3);
    std::normal_distribution<double> noise(120, 40);
    const Volume n = test::makeFloatVolume(d, [&](double, double, double) { return noise(rng); });
    const Prediction p = predictP(n, smooth);
    std::size_t intra = 0;
    for (BlockMode m : p.field.modes)
        intra += m == BlockMode::Intra;
    // A block may still find a patch of the smooth frame near its mean; nearly all must fall back to intra.
    EXPECT_GE(intra * 20, p.field.modes.size() * 19) << intra << " of " << p.field.modes.size();
    // Intra predicts each block's mean: the residual is no worse than the noise around the block means.
    double e = 0, var = 0;
    for (std::size_t i = 0; i < n.voxelCount(); ++i)
        e += std::pow(n.valueAt(i) - p.kernel.valueAt(i), 2);
    const VolumeStats st = n.stats(1);
    var = st.stddev * st.stddev * double(n.voxelCount());
    EXPECT_LT(e, 1.05 * var);
}

TEST(MotionCompensation, IdenticalFramesPickZeroMotionAndPredictExactly) {
    const Volume a = blobs({24, 24, 24});
    const Prediction p = predictP(a, a);
    for (BlockMode m : p.field.modes)
        EXPECT_EQ(m, BlockMode::Zero);
    EXPECT_LE(maxAbsDiff(p.kernel, a), 1e-4);
}

TEST(MotionCompensation, BidirectionalPredictionAveragesBothReferences) {
    // Frames 0 and 2 of a translated series predict frame 1: forward vectors from frame 0, backward from
    // frame 2; the bidirectional mode halves the interpolation error of either.
    const Volume base = blobs({40, 32, 24});
    const TimeSeries ts = translatedSeries(base, 3, {1.0, 0.5, 0.0});
    ComputeContext& cc = test::computeContext();
    MotionEstimator est(cc, {8, 3});
    const MotionSearchResult fwd = est.search(cc, ts.frames[1], ts.frames[0]);
    const MotionSearchResult bwd = est.search(cc, ts.frames[1], ts.frames[2]);
    ModeChoice all{true, true, true, true, true};
    MotionCompensator comp(cc);
    std::vector<ModeCosts> kc, rc;
    const MotionField f = comp.decideModes(cc, ts.frames[1], ts.frames[0], &ts.frames[2], fwd.grid,
                                           fwd.vectors, &bwd.vectors, all, &kc);
    const MotionField r = decideModesReference(ts.frames[1], ts.frames[0], &ts.frames[2], fwd.grid,
                                               fwd.vectors, &bwd.vectors, all, &rc);
    std::size_t agree = 0, bi = 0;
    for (std::size_t b = 0; b < f.modes.size(); ++b) {
        agree += f.modes[b] == r.modes[b];
        bi += r.modes[b] == BlockMode::Bidirectional || r.modes[b] == BlockMode::Backward ||
              r.modes[b] == BlockMode::Forward;
        EXPECT_LE(rc[b][int(BlockMode::Bidirectional)],
                  std::max(rc[b][int(BlockMode::Forward)], rc[b][int(BlockMode::Backward)]) * 1.0001 + 1e-9);
    }
    EXPECT_EQ(agree, f.modes.size());
    EXPECT_EQ(bi, f.modes.size());
    const Volume k = comp.compensate(cc, f, ts.frames[0], &ts.frames[2]);
    const Volume ref = compensateReference(f, ts.frames[0], &ts.frames[2]);
    EXPECT_LE(maxAbsDiff(k, ref), 1e-5 * range(base));
    // A backward mode without a second reference is refused.
    EXPECT_THROW(compensateReference(f, ts.frames[0], nullptr), DataError);
}

namespace {

// A random field over `d` with blocks of `size`: every mode, half-voxel vectors up to 5 voxels (many
// pointing outside the volume: clamp-to-edge), intra values across the range.
// Random modes, vectors and intra values; with `bidirectional` false only the modes of a P frame (intra,
// zero, forward) and no backward vectors.
MotionField randomField(Dims d, std::size_t size, std::mt19937& rng, bool bidirectional = true) {
    std::uniform_int_distribution<int> mode(0, bidirectional ? kBlockModeCount - 1 : 2), comp10(-10, 10);
    MotionField f;
    f.grid = {d, size};
    for (std::size_t b = 0; b < f.grid.count(); ++b) {
        f.modes.push_back(static_cast<BlockMode>(mode(rng)));
        f.forward.push_back(
            {std::int16_t(comp10(rng)), std::int16_t(comp10(rng)), std::int16_t(comp10(rng))});
        if (bidirectional)
            f.backward.push_back(
                {std::int16_t(comp10(rng)), std::int16_t(comp10(rng)), std::int16_t(comp10(rng))});
        f.intraValue.push_back(float(comp10(rng)) * 7.5f);
    }
    return f;
}

// `v` (values about 0..200) moved onto most of `type`'s range: the references in each voxel type.
Volume asType(const Volume& v, ScalarType type) {
    const double scale = type == ScalarType::UInt8 ? 1.0 : type == ScalarType::Float32 ? 0.37 : 300.0;
    const double offset = type == ScalarType::Int16 ? -30000.0 : 0.0;
    Volume s(v.dims(), ScalarType::Float32);
    const auto in = v.values<float>();
    auto out = s.values<float>();
    for (std::size_t i = 0; i < in.size(); ++i)
        out[i] = float(in[i] * scale + offset);
    return s.convertedTo(type);
}

} // namespace

TEST(MotionCompensation, RandomFieldsMatchTheReferenceOnEveryPath) {
    // Random fields on dims that are no multiple of 8: the row kernel (blocks of 8, 16 and 32; vector loads
    // inside rows, lane by lane at the row ends and in the first and last partial groups) and the per-voxel
    // kernel (blocks of 4) against the reference, with references of every voxel type (the row kernel reads
    // them as they are).
    ComputeContext& cc = test::computeContext();
    MotionCompensator comp(cc);
    const Dims d{45, 27, 19};
    std::mt19937 rng(7);
    for (ScalarType type : {ScalarType::Float32, ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16}) {
        const Volume r0 = asType(blobs(d, 11), type), r1 = asType(blobs(d, 12), type);
        for (std::size_t size : {4u, 8u, 16u, 32u}) {
            const MotionField f = randomField(d, size, rng);
            const Volume k = comp.compensate(cc, f, r0, &r1), ref = compensateReference(f, r0, &r1);
            EXPECT_LE(maxAbsDiff(k, ref), 1e-5 * range(r0))
                << "block size " << size << ", " << scalarTypeName(type);
        }
    }
}

TEST(MotionCompensation, TinyVolumeMatchesTheReferenceOnBothKernels) {
    // The per-voxel kernel (blocks of 4) and the row kernel (blocks of 8) on a 13 x 9 x 6 volume: small
    // enough for tests/oclgrind/run_kernels.sh to run both on Oclgrind.
    ComputeContext& cc = test::computeContext();
    MotionCompensator comp(cc);
    const Dims d{13, 9, 6};
    std::mt19937 rng(3);
    const Volume r0 = asType(blobs(d, 5), ScalarType::UInt8), r1 = asType(blobs(d, 6), ScalarType::UInt8);
    for (std::size_t size : {4u, 8u}) {
        const MotionField f = randomField(d, size, rng);
        const Volume k = comp.compensate(cc, f, r0, &r1), ref = compensateReference(f, r0, &r1);
        EXPECT_LE(maxAbsDiff(k, ref), 1e-5 * range(r0)) << "block size " << size;
    }
}

TEST(MotionCompensation, FusedReconstructionEqualsRoundedPredictionPlusResidual) {
    // The decoder's one-pass reconstruction against the host's steps on the compensation kernel's output
    // (quantisedPrediction, then addResidual), bit for bit: every voxel type, every row-kernel block size and
    // the per-voxel fallback, dims no multiple of 8 along any axis. The residuals hold exact halves (ties
    // round to even), values far outside the type's range (clamped) and, for integer types, NaN (0, as the
    // host's conversion gives).
    ComputeContext& cc = test::computeContext();
    MotionCompensator comp(cc);
    const Dims d{45, 27, 19};
    std::mt19937 rng(21);
    std::uniform_int_distribution<int> halves(-400, 400), special(0, 40);
    for (ScalarType type : {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16, ScalarType::Float32}) {
        const Volume r0 = asType(blobs(d, 13), type), r1 = asType(blobs(d, 14), type);
        Volume residual(d, ScalarType::Float32);
        for (float& v : residual.values<float>()) {
            const int s = special(rng);
            v = s == 0                                  ? 1e6f
                : s == 1                                ? -1e6f
                : s == 2 && type != ScalarType::Float32 ? NAN
                                                        : 0.5f * float(halves(rng));
        }
        for (std::size_t size : {4u, 8u, 16u, 32u}) {
            const MotionField f = randomField(d, size, rng);
            const Volume expected = codec::addResidual(
                codec::quantisedPrediction(comp.compensate(cc, f, r0, &r1), type), residual, type);
            const Volume fused = comp.reconstruct(cc, f, r0, &r1, residual, type);
            EXPECT_EQ(fused.type(), type);
            EXPECT_TRUE(fused == expected) << "block size " << size << ", " << scalarTypeName(type);
            if (type == ScalarType::Float32) continue;
            // A float reference (moved by a global shift) with frames of the integer type, and a prediction
            // kept float (lossy integer frames): the host steps those decoders took before, bit for bit.
            const Volume moved = asType(blobs(d, 13), ScalarType::Float32);
            const MotionField forwardOnly = randomField(d, size, rng, false);
            const Volume movedExpected = codec::addResidual(
                codec::quantisedPrediction(comp.compensate(cc, forwardOnly, moved, nullptr), type), residual,
                type);
            const Volume movedFused = comp.reconstruct(cc, forwardOnly, moved, nullptr, residual, type);
            EXPECT_EQ(movedFused.type(), type);
            EXPECT_TRUE(movedFused == movedExpected)
                << "moved reference, block size " << size << ", " << scalarTypeName(type);
            const Volume floatExpected = codec::addResidual(
                codec::quantisedPrediction(comp.compensate(cc, f, r0, &r1), ScalarType::Float32), residual,
                type);
            const Volume floatFused = comp.reconstruct(cc, f, r0, &r1, residual, type, false);
            EXPECT_TRUE(floatFused == floatExpected)
                << "float prediction, block size " << size << ", " << scalarTypeName(type);
        }
    }
    // The residual must be Float32 on the frame's grid.
    const MotionField f = randomField(d, 8, rng);
    const Volume r0 = asType(blobs(d, 13), ScalarType::UInt8);
    EXPECT_THROW(comp.reconstruct(cc, f, r0, &r0, Volume(d, ScalarType::UInt8), ScalarType::UInt8),
                 DataError);
    EXPECT_THROW(
        comp.reconstruct(cc, f, r0, &r0, Volume({45, 27, 18}, ScalarType::Float32), ScalarType::UInt8),
        DataError);
}

TEST(MotionCompensation, BadFieldsAreRefused) {
    const Volume a = blobs({16, 16, 16});
    MotionField f;
    f.grid = {a.dims(), 8};
    f.modes.assign(7, BlockMode::Zero); // 8 blocks needed
    f.forward.assign(7, {});
    f.intraValue.assign(7, 0);
    EXPECT_THROW(compensateReference(f, a, nullptr), DataError);
    f.modes.assign(8, static_cast<BlockMode>(9));
    f.forward.assign(8, {});
    f.intraValue.assign(8, 0);
    EXPECT_THROW(compensateReference(f, a, nullptr), DataError);
    ComputeContext& cc = test::computeContext();
    MotionCompensator comp(cc);
    EXPECT_THROW(comp.compensate(cc, f, a, nullptr), DataError);
}

// ------------------------------------------------------------------------------ vector coding

TEST(MotionVectorCoding, MedianPredictorUsesLeftUpFront) {
    const Dims blocks{3, 3, 3};
    std::vector<MotionVector> v(27);
    v[13 - 1] = {4, 0, -2};  // left of the centre block
    v[13 - 3] = {2, 6, -2};  // up
    v[13 - 9] = {-8, 2, 10}; // front
    EXPECT_EQ(medianPredictor(v, blocks, 13), (MotionVector{2, 2, -2}));
    EXPECT_EQ(medianPredictor(v, blocks, 0), MotionVector{}); // no neighbours: zero
    v[0] = {5, 5, 5};
    EXPECT_EQ(medianPredictor(v, blocks, 1), MotionVector{}); // left only: median(5, 0, 0) = 0
}

TEST(MotionVectorCoding, FieldsRoundTripCompactly) {
    std::mt19937 rng(9);
    for (bool bidirectional : {false, true}) {
        MotionField f;
        f.grid = {{61, 40, 33}, 8};
        const std::size_t n = f.grid.count();
        std::uniform_int_distribution<int> mode(0, bidirectional ? 4 : 2), comp(-30, 30);
        for (std::size_t b = 0; b < n; ++b) {
            f.modes.push_back(static_cast<BlockMode>(mode(rng)));
            f.forward.push_back({std::int16_t(comp(rng)), std::int16_t(comp(rng)), std::int16_t(comp(rng))});
            if (bidirectional)
                f.backward.push_back(
                    {std::int16_t(comp(rng)), std::int16_t(comp(rng)), std::int16_t(comp(rng))});
            f.intraValue.push_back(float(comp(rng)) * 1.37f);
        }
        const std::vector<std::uint8_t> bytes = encodeMotionField(f);
        EXPECT_EQ(decodeMotionField(bytes, f.grid, "test"), canonicalMotionField(f));
        // Truncation is detected; byte flips never crash (they decode or throw IoError).
        for (std::size_t cut = 0; cut < bytes.size(); cut += std::max<std::size_t>(1, bytes.size() / 40))
            EXPECT_THROW(decodeMotionField(std::span(bytes).first(cut), f.grid, "test"), IoError);
        for (std::size_t i = 0; i < bytes.size(); ++i) {
            std::vector<std::uint8_t> bad = bytes;
            bad[i] ^= 0x5A;
            try {
                decodeMotionField(bad, f.grid, "test");
            } catch (const IoError&) {
            }
        }
        EXPECT_THROW(decodeMotionField(bytes, {{8, 8, 8}, 8}, "test"), IoError) << "another grid";
    }
    // A smooth field (one vector everywhere, some zero blocks) costs a few bytes: the differences vanish.
    MotionField s;
    s.grid = {{128, 128, 128}, 8};
    const std::size_t n = s.grid.count();
    s.modes.assign(n, BlockMode::Forward);
    s.forward.assign(n, MotionVector{3, -2, 1});
    s.intraValue.assign(n, 0);
    for (std::size_t b = 0; b < n; b += 17)
        s.modes[b] = BlockMode::Zero;
    const std::vector<std::uint8_t> bytes = encodeMotionField(s);
    EXPECT_LT(bytes.size(), 300u) << n << " blocks"; // under 0.6 bits per block
    EXPECT_EQ(decodeMotionField(bytes, s.grid, "smooth"), canonicalMotionField(s));
    // Out-of-range vectors are refused before anything is written.
    s.forward[5] = {64, 0, 0};
    EXPECT_THROW(encodeMotionField(s), DataError);
}
