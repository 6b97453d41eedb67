// Wavelet codec: lossless exactness, --max-error on every voxel, PSNR / bpv targets, region and level
// decoding against full decodes, hard inputs, and corruption detection (byte flips and truncations).
#include "core/Error.hpp"
#include "host/io/VolumeIo.hpp"
#include "tests/TestUtil.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/transform/BrickTransform.hpp"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>

using namespace volcl;

namespace {

// Smooth field plus noise: compresses like real data (unlike white noise) and has edges at brick seams.
Volume makeVolume(Dims d, ScalarType type, unsigned seed = 1, double noise = 2.0) {
    Volume v(d, type);
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0, noise);
    const double hi = type == ScalarType::UInt8 ? 255 : type == ScalarType::Float32 ? 1000 : 4000;
    const double lo = type == ScalarType::Int16 ? -2000 : 0;
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x) {
                double s = 0.5 + 0.25 * std::sin(0.21 * double(x)) * std::cos(0.17 * double(y)) +
                           0.2 * std::sin(0.13 * double(z));
                if ((x / 9 + y / 7 + z / 5) % 3 == 0) s += 0.1; // discontinuities
                double val = lo + (hi - lo) * std::clamp(s, 0.0, 1.0) + n(rng);
                val = std::clamp(val, lo, hi);
                const std::size_t i = v.index(x, y, z);
                switch (type) {
                case ScalarType::UInt8:
                    v.values<std::uint8_t>()[i] = static_cast<std::uint8_t>(std::lround(val));
                    break;
                case ScalarType::UInt16:
                    v.values<std::uint16_t>()[i] = static_cast<std::uint16_t>(std::lround(val));
                    break;
                case ScalarType::Int16:
                    v.values<std::int16_t>()[i] = static_cast<std::int16_t>(std::lround(val));
                    break;
                case ScalarType::Float32:
                    v.values<float>()[i] = static_cast<float>(val);
                    break;
                }
            }
    return v;
}

CodecOptions lossless(Wavelet w = Wavelet::Cdf53, EntropyMode m = EntropyMode::Dense,
                      Dims brick = {16, 16, 16}, int levels = 3) {
    CodecOptions o;
    o.rate = RateMode::Lossless;
    o.wavelet = w;
    o.entropy = m;
    o.brick = brick;
    o.levels = levels;
    o.chooseExtent = false; // the brick asked for, also where it is the default
    return o;
}

CodecOptions lossy(RateMode r, double target, Dims brick = {16, 16, 16}, int levels = 3) {
    CodecOptions o;
    o.rate = r;
    o.target = target;
    o.brick = brick;
    o.levels = levels;
    o.chooseExtent = false; // the brick asked for, also where it is the default
    return o;
}

Volume roundTrip(const Volume& v, const CodecOptions& o, EncodeReport* rep = nullptr) {
    ComputeContext& cc = test::computeContext();
    const auto bytes = encodeVolume(cc, v, o, rep);
    return decodeVolume(cc, bytes);
}

// Each brick's level-k band in `lv` (a level-k decode of a lossless integer file made from v) against the
// reference transform of the brick's original voxels, clamped to the voxel type as the decoder does.
void expectLowBandsOfReference(const VczReader& reader, const Volume& v, const Volume& lv, int k, Wavelet w) {
    const VczHeader& h = reader.header();
    const double lo = v.type() == ScalarType::Int16 ? -32768 : 0;
    const double hi = v.type() == ScalarType::UInt8 ? 255 : v.type() == ScalarType::UInt16 ? 65535 : 32767;
    for (std::size_t b = 0; b < h.brickCount(); ++b) {
        const Dims bo = h.brickOrigin(b), bd = h.brickDims(b);
        const Volume crop = v.cropped(bo, {bo.x + bd.x, bo.y + bd.y, bo.z + bd.z});
        std::vector<std::int32_t> c(bd.count());
        for (std::size_t i = 0; i < c.size(); ++i)
            c[i] = static_cast<std::int32_t>(crop.valueAt(i));
        reference::forward3d(std::span<std::int32_t>(c), bd, h.levels, w);
        reference::inverse3d(std::span<std::int32_t>(c), bd, h.levels, w, k);
        const Dims bl = levelDims(bd, k);
        for (std::size_t z = 0; z < bl.z; ++z)
            for (std::size_t y = 0; y < bl.y; ++y)
                for (std::size_t x = 0; x < bl.x; ++x) {
                    const double want = std::clamp<double>(c[(z * bd.y + y) * bd.x + x], lo, hi);
                    ASSERT_EQ(lv.valueAt(lv.index((bo.x >> k) + x, (bo.y >> k) + y, (bo.z >> k) + z)), want)
                        << "brick " << b << " level " << k;
                }
    }
}

} // namespace

TEST(CodecLossless, BitExactOnAwkwardSizesTypesAndWavelets) {
    const Dims sizes[] = {{1, 1, 1},    {1, 37, 1},   {23, 1, 1},  {2, 3, 5},
                          {17, 19, 23}, {31, 29, 37}, {40, 33, 17}};
    for (ScalarType t : {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16}) {
        for (Dims d : sizes) {
            const Volume v = makeVolume(d, t, unsigned(d.x + d.y));
            for (Wavelet w : {Wavelet::Cdf53, Wavelet::Haar, Wavelet::Cdf26}) {
                for (EntropyMode m : {EntropyMode::Dense, EntropyMode::Fast}) {
                    const auto bytes = encodeVolume(test::computeContext(), v, lossless(w, m));
                    const Volume out = decodeVolume(test::computeContext(), bytes);
                    ASSERT_TRUE(out == v) << scalarTypeName(t) << " " << d.x << "x" << d.y << "x" << d.z
                                          << " " << waveletName(w) << " mode " << int(m);
                    // The header's value range (from the bricks' ranges) is the volume's.
                    const VczHeader h = readVczHeader(bytes, "mem");
                    const VolumeStats st = v.stats(1);
                    EXPECT_EQ(h.valueMin, st.min);
                    EXPECT_EQ(h.valueMax, st.max);
                }
            }
        }
    }
}

// Transform rounds bound the batch memory of one launch: every brick lands in exactly one round, with its
// group's dims; a round stays within the budget unless it is one brick larger than the budget.
TEST(TransformRounds, PackWithinBudgetAndCoverEveryBrickOnce) {
    const std::vector<codec::BrickGroup> groups = {{{64, 64, 64}, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10}},
                                                   {{45, 64, 64}, {11, 12, 13}},
                                                   {{200, 200, 200}, {14}},
                                                   {{8, 8, 8}, {15, 16}}};
    auto bytes = [](Dims d) { return BrickBatch<std::int32_t>::strideFor(d) * sizeof(std::int32_t); };
    for (std::size_t budget :
         {std::size_t(1), std::size_t(3) << 20, std::size_t(5) << 20, std::size_t(1) << 30}) {
        const auto rounds = codec::transformRounds(groups, bytes, budget);
        std::vector<int> seen(17, 0);
        for (const auto& round : rounds) {
            ASSERT_FALSE(round.empty());
            std::size_t used = 0, count = 0;
            for (const codec::BrickGroup& g : round) {
                ASSERT_FALSE(g.bricks.empty());
                for (std::size_t b : g.bricks) {
                    ++seen[b];
                    const Dims want = b < 11    ? Dims{64, 64, 64}
                                      : b < 14  ? Dims{45, 64, 64}
                                      : b == 14 ? Dims{200, 200, 200}
                                                : Dims{8, 8, 8};
                    EXPECT_EQ(g.dims, want) << "brick " << b;
                }
                used += g.bricks.size() * bytes(g.dims);
                count += g.bricks.size();
            }
            EXPECT_TRUE(used <= budget || count == 1) << "budget " << budget << ": " << used << " bytes";
        }
        for (std::size_t b = 0; b < seen.size(); ++b)
            EXPECT_EQ(seen[b], 1) << "brick " << b << " budget " << budget;
        if (budget == (std::size_t(1) << 30)) EXPECT_EQ(rounds.size(), 1u);
        if (budget == 1) EXPECT_EQ(rounds.size(), 17u);
    }
}

// The header check bounds what decoding holds at once, not only the frame: the frame, one brick's 32-bit
// coefficients and the largest corrections list the brick may carry (decompressed and decoded): 26 bytes
// per voxel of a uint8 brick and the list's 10-byte count beside its frame. A budget the frame fits in but
// that working set does not is refused before anything is allocated.
TEST(CodecLossless, HeaderBudgetCoversTheFrameAndOneBricksDecodingState) {
    const Volume v = makeVolume({16, 16, 16}, ScalarType::UInt8, 3);
    const auto bytes =
        encodeVolume(test::computeContext(), v, lossless(Wavelet::Cdf53, EntropyMode::Fast, {16, 16, 16}, 2));
    const std::size_t frame = 16 * 16 * 16, workingSet = frame + frame * (4 + 5 + 1 + 16) + 10;
    EXPECT_NO_THROW(readVczHeader(bytes, "mem", workingSet));
    for (const std::size_t budget : {workingSet - 1, 2 * frame}) {
        try {
            (void)readVczHeader(bytes, "mem", budget);
            ADD_FAILURE() << "budget " << budget << " accepted";
        } catch (const IoError& e) {
            EXPECT_NE(std::string(e.what()).find("corrections of a 16x16x16 brick"), std::string::npos)
                << e.what();
        }
    }
}

// A volume of more bricks of several shapes than two transform rounds hold (a round of 8 MB holds 8 bricks of
// 64^3 int32) decodes exactly, whole and at a coarser level, and a lossy encode holds its bound on every voxel.
TEST(CodecLossless, VolumeOfManyRoundsRoundTrips) {
    const Volume v = makeVolume({300, 200, 140}, ScalarType::UInt16, 7);
    ComputeContext& cc = test::computeContext();
    const auto bytes = encodeVolume(cc, v, lossless(Wavelet::Cdf53, EntropyMode::Dense, {64, 64, 64}, 4));
    ASSERT_GT(readVczHeader(bytes, "mem").brickCount(),
              2 * codec::kTransformRoundBytes / (std::size_t(1) << 20));
    EXPECT_TRUE(decodeVolume(cc, bytes) == v);
    const VczReader reader(bytes, "mem");
    DecodeOptions o;
    o.level = 2;
    expectLowBandsOfReference(reader, v, reader.decode(cc, o), 2, Wavelet::Cdf53);
    CodecOptions e = lossy(RateMode::MaxError, 3.0, {64, 64, 64}, 4);
    const Volume back = decodeVolume(cc, encodeVolume(cc, v, e));
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        ASSERT_LE(std::abs(back.valueAt(i) - v.valueAt(i)), 3.0) << "voxel " << i;
}

TEST(CodecLossless, ExtremeSixteenBitAlternationIsExact) {
    Volume v({33, 18, 20}, ScalarType::UInt16);
    auto s = v.values<std::uint16_t>();
    for (std::size_t i = 0; i < s.size(); ++i)
        s[i] = ((i + i / 33 + i / (33 * 18)) & 1) ? 65535 : 0;
    Volume w({33, 18, 20}, ScalarType::Int16);
    auto t = w.values<std::int16_t>();
    for (std::size_t i = 0; i < t.size(); ++i)
        t[i] = (i & 1) ? 32767 : -32768;
    for (const Volume* vol : {&v, &w})
        for (Wavelet wl : {Wavelet::Cdf53, Wavelet::Haar, Wavelet::Cdf26}) {
            EXPECT_TRUE(roundTrip(*vol, lossless(wl, EntropyMode::Dense, {32, 32, 32}, 5)) == *vol)
                << waveletName(wl);
        }
}

TEST(CodecLossless, ConstantVolumeIsTiny) {
    Volume v({64, 64, 64}, ScalarType::UInt8);
    for (auto& x : v.values<std::uint8_t>())
        x = 77;
    EncodeReport rep;
    const Volume out = roundTrip(v, lossless(Wavelet::Cdf53, EntropyMode::Dense, {32, 32, 32}, 4), &rep);
    EXPECT_TRUE(out == v);
    // Only fixed costs remain: header, index (40 bytes per brick) and per-brick section headers.
    EXPECT_LT(rep.bytes, 1500u);
}

TEST(CodecLossless, FloatKeepsNanInfAndHugeRangeBitForBit) {
    Volume v = makeVolume({19, 17, 13}, ScalarType::Float32);
    auto s = v.values<float>();
    s[0] = std::numeric_limits<float>::quiet_NaN();
    s[1] = std::numeric_limits<float>::infinity();
    s[2] = -std::numeric_limits<float>::infinity();
    s[3] = 3.0e38f;
    s[4] = 1.0e-38f;
    s[5] = -0.0f;
    const Volume out = roundTrip(v, lossless());
    ASSERT_EQ(std::memcmp(out.bytes().data(), v.bytes().data(), v.byteSize()), 0);
}

TEST(CodecLossy, MaxErrorHoldsOnEveryVoxel) {
    const Dims d{37, 29, 23};
    for (ScalarType t : {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16, ScalarType::Float32}) {
        const Volume v = makeVolume(d, t, 5, 3.0);
        for (double e : {0.5, 1.0, 2.0, 7.5}) {
            for (Wavelet w : {Wavelet::Cdf97, Wavelet::Cdf53, Wavelet::Cdf26}) {
                CodecOptions o = lossy(RateMode::MaxError, e);
                o.wavelet = w;
                EncodeReport rep;
                const Volume out = roundTrip(v, o, &rep);
                ASSERT_TRUE(out.sameGrid(v));
                EXPECT_LE(maxAbsError(v, out), e) << scalarTypeName(t) << " E=" << e << " " << waveletName(w);
                EXPECT_LE(rep.maxError, e);
            }
        }
    }
}

TEST(CodecLossy, MaxErrorOnHugeDynamicRangeFloats) {
    Volume v({24, 20, 18}, ScalarType::Float32);
    auto s = v.values<float>();
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> ex(-30, 30);
    for (auto& x : s)
        x = static_cast<float>(std::pow(10.0, ex(rng)) * ((rng() & 1) ? 1 : -1));
    const Volume out = roundTrip(v, lossy(RateMode::MaxError, 1e-3));
    EXPECT_LE(maxAbsError(v, out), 1e-3);
}

// NaN/Inf in lossy modes: test_codec_nan.cpp.

// Finite voxels near the float limit whose wavelet coefficients overflow to Inf: those coefficients code as
// 0 and the voxels they leave wrong are stored exactly (here all of them), never coded as garbage.
TEST(CodecLossy, ValuesBeyondTheFloatTransformsRangeAreStoredExactly) {
    Volume v({16, 12, 10}, ScalarType::Float32);
    auto s = v.values<float>();
    for (std::size_t i = 0; i < s.size(); ++i)
        s[i] = (i % 2 ? 1.0f : -1.0f) * 3.0e38f;
    EXPECT_EQ(roundTrip(v, lossy(RateMode::Psnr, 40)), v);
    EXPECT_EQ(roundTrip(v, lossy(RateMode::MaxError, 1e30)), v);
    EXPECT_EQ(roundTrip(v, CodecOptions{}), v); // lossless keeps them bit for bit
}

// A fixed-step encode without error measurement codes straight from the transform (no coefficient copy);
// it must write the same file as the measured path, also when huge magnitudes force larger steps (the
// direct path detects that and falls back).
TEST(CodecLossy, DirectFixedStepEncodeWritesTheSameFile) {
    ComputeContext& cc = test::computeContext();
    Volume huge({24, 20, 18}, ScalarType::Float32);
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> ex(-30, 30);
    for (auto& x : huge.values<float>())
        x = static_cast<float>(std::pow(10.0, ex(rng)) * ((rng() & 1) ? 1 : -1));
    const std::vector<std::pair<Volume, double>> cases{
        {makeVolume({37, 29, 23}, ScalarType::UInt16, 3, 20.0), 8.0},
        {makeVolume({20, 16, 12}, ScalarType::UInt8), 0.5},
        {huge, 1e-6}}; // steps below maxAbs / 2^29: raised by the encoder
    for (const auto& [v, step] : cases)
        for (EntropyMode m : {EntropyMode::Fast, EntropyMode::Dense}) {
            CodecOptions o = lossy(RateMode::Psnr, 40);
            o.entropy = m;
            o.step = step;
            const auto measured = encodeVolume(cc, v, o);
            o.measureError = false;
            EncodeReport rep;
            const auto direct = encodeVolume(cc, v, o, &rep);
            EXPECT_EQ(direct, measured) << "step " << step << " entropy " << int(m);
            EXPECT_EQ(rep.step, step);
        }
}

TEST(CodecLossy, PsnrTargetIsMetWithinHalfADecibel) {
    const Volume v = makeVolume({48, 40, 36}, ScalarType::UInt16, 3, 20.0);
    for (double p : {40.0, 50.0, 60.0}) {
        EncodeReport rep;
        const Volume out = roundTrip(v, lossy(RateMode::Psnr, p, {16, 16, 16}, 3), &rep);
        const double got = psnr(v, out);
        EXPECT_GE(got, p) << p;
        EXPECT_LE(got, p + 0.5) << p;
        EXPECT_NEAR(got, rep.psnr, 1e-6);
    }
}

// From 32 bricks up the step is estimated on a sample of 1/8 of the bricks and checked by at most two full
// rounds (one correction) before the full search would run. Hard cases for the estimate: a sample of
// background bricks (a volume zero but for one corner), a single outlier that sets the range in a brick the
// sample misses, floats over 60 decades, a constant volume. The PSNR is measured here from the decode.
TEST(CodecLossy, PsnrFromASampleOfBricksMeetsTheTarget) {
    const Dims d{48, 40, 36}; // bricks of 8: 6 x 5 x 5 = 150
    const Volume smooth = makeVolume(d, ScalarType::UInt16, 3, 20.0);
    Volume corner(d, ScalarType::UInt8);
    Volume outlier = makeVolume(d, ScalarType::UInt8, 5, 1.0);
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x)
                if (x < 12 && y < 12 && z < 12)
                    corner.values<std::uint8_t>()[corner.index(x, y, z)] =
                        std::uint8_t((x * 7 + y * 3 + z) % 200);
    for (auto& x : outlier.values<std::uint8_t>())
        x = std::uint8_t(x / 4);
    outlier.values<std::uint8_t>()[outlier.index(47, 39, 35)] = 255;
    Volume huge(d, ScalarType::Float32);
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> ex(-30, 30);
    for (auto& x : huge.values<float>())
        x = static_cast<float>(std::pow(10.0, ex(rng)) * ((rng() & 1) ? 1 : -1));
    Volume constant(d, ScalarType::UInt16);
    for (auto& x : constant.values<std::uint16_t>())
        x = 1234;
    const std::vector<std::pair<const char*, const Volume*>> cases{{"smooth", &smooth},
                                                                   {"corner", &corner},
                                                                   {"outlier", &outlier},
                                                                   {"huge", &huge},
                                                                   {"constant", &constant}};
    for (const auto& [name, v] : cases)
        for (double p : {40.0, 50.0, 60.0}) {
            EncodeReport rep;
            const Volume out = roundTrip(*v, lossy(RateMode::Psnr, p, {8, 8, 8}, 3), &rep);
            const double got = psnr(*v, out);
            EXPECT_GE(got, p) << name << " at " << p << " dB";
            // The report leaves voxel-coded bricks' errors out of the rate control's sums: a lower bound.
            EXPECT_GE(rep.psnr, p) << name << " at " << p << " dB";
            EXPECT_GE(got, rep.psnr - 1e-6) << name << " at " << p << " dB: reported " << rep.psnr;
            if (std::string(name) == "smooth") {
                EXPECT_LE(got, p + 0.5) << name << " at " << p << " dB";
                EXPECT_GT(rep.profile.sampleTrials, 0) << "the sample estimate ran";
                EXPECT_LE(rep.profile.trials, 2)
                    << name << " at " << p << " dB: at most one correction round";
            }
        }
}

TEST(CodecLossy, BitsPerVoxelTargetIsNotExceeded) {
    const Volume v = makeVolume({48, 40, 36}, ScalarType::UInt8, 4, 4.0);
    for (double r : {0.5, 1.0, 2.0}) {
        EncodeReport rep;
        const Volume out = roundTrip(v, lossy(RateMode::Bpv, r, {16, 16, 16}, 3), &rep);
        EXPECT_LE(rep.bitsPerVoxel, r);
        EXPECT_GT(rep.bitsPerVoxel, 0.6 * r) << "rate control left most of the budget unused";
        EXPECT_GT(psnr(v, out), 20.0);
    }
}

TEST(CodecAccess, RegionDecodeEqualsCropOfFullDecode) {
    ComputeContext& cc = test::computeContext();
    const Volume v = makeVolume({45, 38, 29}, ScalarType::UInt16, 8, 10.0);
    for (const CodecOptions& o : {lossless(), lossy(RateMode::MaxError, 3.0), lossy(RateMode::Psnr, 45.0)}) {
        const auto bytes = encodeVolume(cc, v, o);
        const Volume full = decodeVolume(cc, bytes);
        for (const Region& r : {Region{{0, 0, 0}, {1, 1, 1}}, Region{{3, 5, 7}, {40, 17, 29}},
                                Region{{15, 15, 15}, {17, 17, 17}}, Region{{44, 37, 28}, {45, 38, 29}}}) {
            DecodeOptions d;
            d.region = r;
            const Volume part = decodeVolume(cc, bytes, d);
            const Volume ref = full.cropped(r.lo, r.hi);
            ASSERT_TRUE(part.sameGrid(ref));
            ASSERT_TRUE(part == ref);
        }
    }
}

// The inverse kernel's own voxel conversion and placement (CPU devices) against the host's, on every voxel
// type, lossless and lossy (saturated regions make the lossy reconstruction overshoot, so the clamps are
// exercised; --max-error adds corrections), edge bricks of several shapes, and a brick-aligned region
// (placed relative to its corner).
TEST(CodecAccess, DevicePlacementEqualsHostPlacement) {
    ComputeContext& cc = test::computeContext();
    for (ScalarType t : {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16, ScalarType::Float32}) {
        // Slabs at each end of the type's range (floats: +-1e5, far beyond the rest), set in float and
        // converted (which clamps to the type).
        Volume f = makeVolume({37, 29, 23}, t, 11, 4.0).convertedTo(ScalarType::Float32);
        for (std::size_t z = 0; z < 23; ++z)
            for (std::size_t y = 0; y < 29; ++y)
                for (std::size_t x = 0; x < 6; ++x) {
                    f.values<float>()[f.index(x, y, z)] = -1e5f;
                    f.values<float>()[f.index(36 - x, y, z)] = 1e5f;
                }
        const Volume v = f.convertedTo(t);
        std::vector<CodecOptions> opts = {lossless(), lossless(Wavelet::Haar, EntropyMode::Fast),
                                          lossy(RateMode::Bpv, 0.5), lossy(RateMode::MaxError, 2.0)};
        if (t == ScalarType::Float32) opts.erase(opts.begin(), opts.begin() + 2); // lossless floats: raw bits
        for (const CodecOptions& o : opts) {
            const auto bytes = encodeVolume(cc, v, o);
            for (const Region& r : {Region{{0, 0, 0}, {37, 29, 23}}, Region{{16, 0, 16}, {37, 29, 23}}}) {
                DecodeOptions onDevice, onHost;
                onDevice.region = onHost.region = r;
                onHost.placeOnDevice = false;
                const Volume a = decodeVolume(cc, bytes, onDevice), b = decodeVolume(cc, bytes, onHost);
                ASSERT_TRUE(a.sameGrid(b));
                EXPECT_TRUE(a == b) << scalarTypeName(t) << " rate " << int(o.rate) << " region x0 "
                                    << r.lo.x;
            }
        }
    }
}

TEST(CodecAccess, LevelDecodeIsTheLowBandAndRegionsAgree) {
    ComputeContext& cc = test::computeContext();
    const Dims d{45, 38, 29};
    const Volume v = makeVolume(d, ScalarType::Int16, 6, 10.0);
    const auto bytes = encodeVolume(cc, v, lossless(Wavelet::Cdf53, EntropyMode::Dense, {16, 16, 16}, 3));
    VczReader reader(bytes, "mem");
    for (int k = 1; k <= 3; ++k) {
        DecodeOptions o;
        o.level = k;
        const Volume lv = reader.decode(cc, o);
        const Dims ld = levelDims(d, k);
        ASSERT_EQ(lv.dims(), ld);
        EXPECT_DOUBLE_EQ(lv.spacing[0], double(1 << k));
        expectLowBandsOfReference(reader, v, lv, k, Wavelet::Cdf53);
        // Region at a level equals the matching crop of the level decode.
        o.region = Region{{5, 9, 3}, {41, 30, 27}};
        const Volume part = reader.decode(cc, o);
        const std::size_t f = std::size_t(1) << k;
        auto up = [f](std::size_t x) { return (x + f - 1) / f; };
        const Volume ref = lv.cropped({up(5), up(9), up(3)}, {up(41), up(30), up(27)});
        ASSERT_TRUE(part == ref) << "level " << k;
        // Bricks on demand match too.
        const Volume brick = reader.decodeBrick(cc, 0, 1, k);
        const Dims b1 = reader.header().brickOrigin(1), bd1 = reader.header().brickDims(1);
        const Volume bref = lv.cropped({b1.x >> k, b1.y >> k, b1.z >> k},
                                       {(b1.x >> k) + levelDims(bd1, k).x, (b1.y >> k) + levelDims(bd1, k).y,
                                        (b1.z >> k) + levelDims(bd1, k).z});
        ASSERT_TRUE(brick == bref);
    }
}

// Lossless integer bricks of one value (min == max in the index) are filled, not decoded: exact at every
// level, in regions that cut them and brick by brick, for zero, the type's extremes and other values, with
// every reversible filter and both coders; damage to such a brick's payload is still detected.
TEST(CodecAccess, UniformBricksDecodeExactlyAtEveryLevel) {
    ComputeContext& cc = test::computeContext();
    const Dims d{45, 38, 29};
    for (ScalarType t : {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16}) {
        Volume f = makeVolume(d, t, 9, 6.0).convertedTo(ScalarType::Float32);
        // Bricks (16^3, edge bricks 13/6/13 wide): (0,0,0) zero, (1,0,0) the type's maximum, (2,1,0) an edge
        // brick at the type's minimum, (0,2,1) a corner brick of 77, and (1,1,1) uniform but for one voxel.
        const std::array<std::pair<Dims, float>, 5> fills{
            {{{0, 0, 0}, 0.f}, {{1, 0, 0}, 1e6f}, {{2, 1, 0}, -1e6f}, {{0, 2, 1}, 77.f}, {{1, 1, 1}, 5.f}}};
        for (const auto& [g, value] : fills)
            for (std::size_t z = g.z * 16; z < std::min(d.z, g.z * 16 + 16); ++z)
                for (std::size_t y = g.y * 16; y < std::min(d.y, g.y * 16 + 16); ++y)
                    for (std::size_t x = g.x * 16; x < std::min(d.x, g.x * 16 + 16); ++x)
                        f.values<float>()[f.index(x, y, z)] = value;
        f.values<float>()[f.index(20, 20, 20)] = 6.f;
        const Volume v = f.convertedTo(t); // clamps +-1e6 to the type's range
        for (auto [w, m] :
             {std::pair{Wavelet::Cdf53, EntropyMode::Dense}, std::pair{Wavelet::Haar, EntropyMode::Fast},
              std::pair{Wavelet::Cdf26, EntropyMode::Dense}}) {
            const auto bytes = encodeVolume(cc, v, lossless(w, m));
            VczReader reader(bytes, "mem");
            std::size_t uniform = 0;
            for (const VczBrickEntry& e : reader.header().bricks[0])
                uniform += e.min == e.max ? 1 : 0;
            ASSERT_EQ(uniform, 4u);
            ASSERT_TRUE(reader.decode(cc) == v) << scalarTypeName(t);
            for (int k = 0; k <= 3; ++k) {
                DecodeOptions o;
                o.level = k;
                const Volume lv = reader.decode(cc, o);
                expectLowBandsOfReference(reader, v, lv, k, w);
                o.region = Region{{5, 9, 3}, {41, 38, 27}};
                const std::size_t s = std::size_t(1) << k;
                auto up = [s](std::size_t x) { return (x + s - 1) / s; };
                EXPECT_TRUE(reader.decode(cc, o) ==
                            lv.cropped({up(5), up(9), up(3)}, {up(41), up(38), up(27)}))
                    << "level " << k;
                // Brick (2,1,0) = 2 + 3 * 1.
                const Volume brick = reader.decodeBrick(cc, 0, 5, k);
                const Dims b5 = reader.header().brickOrigin(5);
                const Dims bl = levelDims(reader.header().brickDims(5), k);
                EXPECT_TRUE(brick ==
                            lv.cropped({b5.x >> k, b5.y >> k, b5.z >> k},
                                       {(b5.x >> k) + bl.x, (b5.y >> k) + bl.y, (b5.z >> k) + bl.z}));
            }
            // A flipped byte in the payload of uniform brick 1 (the type's maximum).
            auto bad = bytes;
            const VczBrickEntry& e1 = reader.header().bricks[0][1];
            bad[e1.offset + e1.size / 2] ^= std::byte{0x40};
            try {
                decodeVolume(cc, bad, {}, "u.vcz");
                ADD_FAILURE() << "damaged uniform brick accepted";
            } catch (const IoError& err) {
                EXPECT_NE(std::string(err.what()).find("brick 1"), std::string::npos) << err.what();
            }
        }
    }
}

TEST(CodecAccess, BadRequestsAreUsageErrors) {
    ComputeContext& cc = test::computeContext();
    const Volume v = makeVolume({20, 20, 20}, ScalarType::UInt8);
    const auto bytes = encodeVolume(cc, v, lossless());
    DecodeOptions o;
    o.level = 4;
    EXPECT_THROW(decodeVolume(cc, bytes, o), UsageError);
    o.level = 0;
    o.region = Region{{0, 0, 0}, {21, 5, 5}};
    EXPECT_THROW(decodeVolume(cc, bytes, o), UsageError);
    EXPECT_THROW(parseRegion("1,2,3:4,5"), UsageError);
    EXPECT_THROW(parseRegion("4,2,3:1,5,6"), UsageError);
    CodecOptions bad = lossless();
    bad.brick = {12, 16, 16};
    EXPECT_THROW(encodeVolume(cc, v, bad), UsageError);
    bad = lossless(Wavelet::Cdf97);
    EXPECT_THROW(encodeVolume(cc, v, bad), UsageError);
}

TEST(CodecCorruption, EveryByteFlipAndTruncationIsDetected) {
    ComputeContext& cc = test::computeContext();
    const Volume v = makeVolume({20, 18, 9}, ScalarType::UInt8, 2, 3.0);
    for (const CodecOptions& o : {lossless(Wavelet::Cdf53, EntropyMode::Dense, {16, 16, 16}, 2),
                                  lossy(RateMode::MaxError, 2.0, {16, 16, 16}, 2)}) {
        const auto good = encodeVolume(cc, v, o);
        ASSERT_TRUE(decodeVolume(cc, good).sameGrid(v));
        std::size_t checked = 0;
        // Every byte of this small file, flipped in two ways.
        for (std::size_t pos = 0; pos < good.size(); ++pos) {
            for (unsigned char mask : {0x01, 0xA5}) {
                auto bad = good;
                bad[pos] ^= std::byte{mask};
                EXPECT_THROW(decodeVolume(cc, bad), IoError) << "flip at " << pos << " of " << good.size();
                ++checked;
            }
        }
        // Every truncation.
        for (std::size_t len = 0; len < good.size(); ++len) {
            std::vector<std::byte> bad(good.begin(), good.begin() + std::ptrdiff_t(len));
            EXPECT_THROW(decodeVolume(cc, bad), IoError) << "truncated to " << len;
            ++checked;
        }
        EXPECT_GT(checked, 3 * good.size() - 1);
    }
}

// Files written before the fast coder's zero-block layout (version 2) are still read; other versions are
// refused. A version-2 file is made by rewriting a current file's version field and header checksum: the
// dense format and fast sections without the zero-block flag did not change.
// Version 2 differs from version 3 only in the fast sections' zero-block flag, which version 2 never sets: the
// version 3 seeds (fuzz/corpus/fuzz_vcz, one per coder) relabelled as version 2 decode alike. Versions 1, 7
// and up, and 4 without a P/B frame, are refused.
TEST(CodecCompatibility, VersionTwoFilesAreReadOthersRefused) {
    ComputeContext& cc = test::computeContext();
    auto withVersion = [](std::vector<std::byte> f, std::uint32_t version) {
        std::memcpy(f.data() + kVczMagic.size(), &version, 4);
        std::uint32_t body;
        std::memcpy(&body, f.data() + kVczMagic.size() + 4, 4);
        const std::size_t end = kVczMagic.size() + 8 + body;
        const std::uint64_t sum =
            vczChecksum(std::span(reinterpret_cast<const std::uint8_t*>(f.data()), end));
        std::memcpy(f.data() + end, &sum, 8);
        return f;
    };
    for (const char* seed : {"v3_lossless_dense_cdf53.vcz", "v3_lossless_fast_haar.vcz"}) {
        const std::string raw =
            test::readFile(std::string(VOLCL_SOURCE_DIR) + "/fuzz/corpus/fuzz_vcz/" + seed);
        const auto* first = reinterpret_cast<const std::byte*>(raw.data());
        const std::vector<std::byte> bytes(first, first + raw.size());
        const Volume v = decodeVolume(cc, bytes);
        const Volume old = decodeVolume(cc, withVersion(bytes, 2));
        EXPECT_TRUE(old == v) << seed;
        // Version 8 exists (float64 files): 9 is the first version no reader knows.
        for (std::uint32_t bad : {1u, 4u, 9u, 0xFFFFFFFFu}) {
            try {
                decodeVolume(cc, withVersion(bytes, bad));
                ADD_FAILURE() << seed << ": version " << bad << " accepted";
            } catch (const IoError& e) {
                const std::string what = e.what();
                EXPECT_TRUE(what.find("unsupported .vcz version") != std::string::npos) << what;
            }
        }
    }
}

// A forged geometry with a valid header checksum: spacing NaN, 0, -1 or inf and a non-finite origin are
// refused when the header is read (spacing 0 was decoded as 1, the others into files volcl refuses).
TEST(CodecCorruption, ForgedGeometryIsRefused) {
    ComputeContext& cc = test::computeContext();
    const auto good = encodeVolume(cc, makeVolume({8, 8, 8}, ScalarType::UInt8), lossless());
    // Body layout (version 6): dims (3 one-byte varints here), six u8 fields, spacing (3 x f64), origin (3 x f64).
    const std::size_t bodyStart = kVczMagic.size() + 8, spacingAt = bodyStart + 9, originAt = spacingAt + 24;
    auto forged = [&](std::size_t at, double value) {
        std::vector<std::byte> f = good;
        std::memcpy(f.data() + at, &value, 8);
        std::uint32_t body;
        std::memcpy(&body, f.data() + kVczMagic.size() + 4, 4);
        const std::size_t end = bodyStart + body;
        const std::uint64_t sum =
            vczChecksum(std::span(reinterpret_cast<const std::uint8_t*>(f.data()), end));
        std::memcpy(f.data() + end, &sum, 8);
        return f;
    };
    double one = 0;
    std::memcpy(&one, good.data() + spacingAt, 8);
    ASSERT_EQ(one, 1.0) << "the layout above no longer matches the format";
    EXPECT_NO_THROW(readVczHeader(forged(spacingAt + 8, 2.5), "f.vcz")); // the forging itself is sound
    const double inf = std::numeric_limits<double>::infinity();
    for (double bad : {std::nan(""), 0.0, -1.0, inf, -0.0})
        for (int axis = 0; axis < 3; ++axis)
            EXPECT_THROW(readVczHeader(forged(spacingAt + 8 * axis, bad), "f.vcz"), IoError)
                << "spacing " << bad << " on axis " << axis;
    for (double bad : {std::nan(""), inf, -inf})
        EXPECT_THROW(readVczHeader(forged(originAt + 8, bad), "f.vcz"), IoError) << "origin " << bad;
}

TEST(CodecCorruption, ErrorNamesTheBrick) {
    ComputeContext& cc = test::computeContext();
    const Volume v = makeVolume({32, 16, 16}, ScalarType::UInt8);
    auto bytes = encodeVolume(cc, v, lossless());
    bytes[bytes.size() - 3] ^= std::byte{0x10};
    try {
        decodeVolume(cc, bytes, {}, "x.vcz");
        FAIL() << "corruption not detected";
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find("x.vcz: brick 1"), std::string::npos) << e.what();
    }
}

TEST(CodecSeries, FramesRoundTrip) {
    ComputeContext& cc = test::computeContext();
    TimeSeries s;
    for (unsigned f = 0; f < 3; ++f)
        s.frames.push_back(makeVolume({20, 17, 11}, ScalarType::UInt8, f + 1));
    s.times = {0.0, 0.5, 1.0};
    const auto bytes = encodeSeries(cc, s, lossless());
    VczReader r(bytes, "series");
    ASSERT_EQ(r.header().frames.size(), 3u);
    for (std::size_t f = 0; f < 3; ++f) {
        DecodeOptions o;
        o.frame = f;
        EXPECT_TRUE(r.decode(cc, o) == s.frames[f]);
        EXPECT_DOUBLE_EQ(r.header().frames[f].time, s.times[f]);
    }
}

namespace {
// BrainWeb is stored as a gzipped headerless volume.
Volume readGzipVolume(const std::filesystem::path& p, Dims d, ScalarType t) {
    Volume v(d, t);
    gzFile f = gzopen(p.string().c_str(), "rb");
    if (!f) throw IoError(p.string() + ": cannot open");
    const int n = gzread(f, v.bytes().data(), static_cast<unsigned>(v.byteSize()));
    gzclose(f);
    if (n != static_cast<int>(v.byteSize())) throw IoError(p.string() + ": short gzip payload");
    return v;
}
} // namespace

TEST(CodecRealData, LosslessIsBitExactOnEverySharedVolume) {
    std::filesystem::path data;
    VOLCL_REQUIRE_SHARED_DATA(data);
    const auto r = data / "regular";
    ReadOptions bucky;
    bucky.dims = Dims{32, 32, 32};
    bucky.type = ScalarType::UInt8;
    std::vector<std::pair<std::string, TimeSeries>> sets;
    sets.emplace_back("Bucky", readVolumeFile(r / "Bucky.raw", bucky));
    for (const char* f : {"nucleon.nrrd", "hydrogenatom.dat", "neghip.slc", "ironProt.vtk",
                          "headsq/quarter.nhdr", "HeadMRVolume.mhd", "walnut.vvd", "froggy/frogtissue.mhd"})
        sets.emplace_back(f, readVolumeFile(r / f));
    TimeSeries brain;
    brain.frames.push_back(readGzipVolume(r / "t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz",
                                          {180, 216, 180}, ScalarType::UInt8));
    sets.emplace_back("brainweb", std::move(brain));
    sets.emplace_back("functional.nii.gz (4D int16)", readVolumeFile(data / "timevarying/functional.nii.gz"));
    ComputeContext& cc = test::computeContext();
    for (const auto& [name, ts] : sets) {
        // Readers that apply scale factors (NIfTI scl_slope) hand out float32: lossless keeps those bit for
        // bit.
        CodecOptions o;
        o.rate = RateMode::Lossless;
        const auto bytes =
            ts.frames.size() == 1 ? encodeVolume(cc, ts.frames[0], o) : encodeSeries(cc, ts, o);
        VczReader reader(bytes, name);
        for (std::size_t f = 0; f < ts.frames.size(); ++f) {
            DecodeOptions d;
            d.frame = f;
            ASSERT_TRUE(reader.decode(cc, d) == ts.frames[f]) << name << " frame " << f;
        }
        std::size_t raw = 0;
        for (const Volume& v : ts.frames)
            raw += v.byteSize();
        EXPECT_LT(bytes.size(), raw) << name << ": lossless did not compress";
    }
}

TEST(CodecRealData, MriTemplateFromDebianIsLossless) {
    const std::filesystem::path mri = "/usr/share/mricron/templates/ch2better.nii.gz";
    if (!std::filesystem::exists(mri)) GTEST_SKIP() << mri << " is absent (apt-get install mricron-data)";
    const Volume v = readVolume(mri);
    ComputeContext& cc = test::computeContext();
    CodecOptions o;
    o.rate = RateMode::Lossless;
    const auto bytes = encodeVolume(cc, v, o);
    EXPECT_TRUE(decodeVolume(cc, bytes) == v);
    // Regression guard: 6.21:1 measured (docs/codec.md). xz -9 reaches 6.49:1 on this volume, so the
    // issue's goal (>= xz) is not met here yet; it is met on the walnut CT and the BrainWeb MRI.
    EXPECT_GT(double(v.byteSize()) / double(bytes.size()), 6.1);
}

// An oriented volume (a 30-degree turn about z with the first axis mirrored, in patient axes) keeps its
// direction and placement through the codec, and a region decodes at the world position of its first
// voxel: origin + D diag(spacing) lo, computed here by hand.
TEST(CodecOrientation, DirectionAndRegionOriginSurviveEncoding) {
    ComputeContext& cc = test::computeContext();
    Volume v({20, 12, 10}, ScalarType::UInt8);
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        v.values<std::uint8_t>()[i] = std::uint8_t((i * 37) % 251);
    const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
    v.direction = {-c, -s, 0, -s, c, 0, 0, 0, 1}; // columns: world directions of the index axes
    v.anatomical = true;
    v.spacing = {0.5, 1.0, 2.0};
    v.origin = {3.0, 4.0, 5.0};
    CodecOptions o;
    o.rate = RateMode::Lossless;
    VczReader reader(encodeVolume(cc, v, o), "oriented.vcz");
    const Volume whole = reader.decode(cc, DecodeOptions{});
    EXPECT_TRUE(whole == v);
    EXPECT_EQ(whole.direction, v.direction);
    EXPECT_TRUE(whole.anatomical);
    DecodeOptions d;
    d.region = Region{{4, 2, 6}, {12, 10, 10}};
    const Volume part = reader.decode(cc, d);
    const double lo[3] = {4 * 0.5, 2 * 1.0, 6 * 2.0}; // lo x spacing
    const std::array<double, 3> expected{3.0 + (-c) * lo[0] + (-s) * lo[1], 4.0 + (-s) * lo[0] + c * lo[1],
                                         5.0 + lo[2]};
    for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(part.origin[std::size_t(i)], expected[std::size_t(i)], 1e-12) << "axis " << i;
        EXPECT_NEAR(v.cropped({4, 2, 6}, {12, 10, 10}).origin[std::size_t(i)], expected[std::size_t(i)],
                    1e-12);
    }
    EXPECT_EQ(part.direction, v.direction);
    EXPECT_TRUE(part == v.cropped({4, 2, 6}, {12, 10, 10}));
}
