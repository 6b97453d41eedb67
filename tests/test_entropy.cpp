// Entropy coder tests: bit-exact round trips of coefficient sections in both modes (random, all-zero,
// single coefficient, extreme magnitudes, tiny and odd subbands) and fuzzing of decodeSection with
// truncated, bit-flipped and random sections (IoError or a clean result, never a crash); every dense decode
// runs both the scalar and the SIMD decoder (where the CPU has it), which must agree, and every dense
// encode (encodeAll) both encoders, which must write the same bytes. The entropy-only
// speed benchmark is bench/entropy_speed.cpp.
#include "core/Error.hpp"
#include "wavelet/entropy/DenseKernels.hpp"
#include "wavelet/entropy/EntropyCoder.hpp"
#include "wavelet/entropy/TestSwitches.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <random>
#include <span>
#include <string>
#include <vector>

using namespace volcl;

namespace {

constexpr std::int32_t kMaxMagnitude = (1 << 30) - 1; // the largest magnitude the caller may pass

struct Coded {
    std::vector<std::vector<std::uint8_t>> sections;
};

// Forces the scalar dense decoder while it lives (the SIMD one is the default where the CPU has it).
struct ScalarDecoder {
    explicit ScalarDecoder(bool on) : before(denseDecoderIsScalar()) { setDenseDecoderScalar(on); }
    ~ScalarDecoder() { setDenseDecoderScalar(before); }
    bool before;
};

// Forces the scalar dense encoder while it lives (the SIMD one is the default where the CPU has it).
struct ScalarEncoder {
    explicit ScalarEncoder(bool on) : before(denseEncoderIsScalar()) { setDenseEncoderScalar(on); }
    ~ScalarEncoder() { setDenseEncoderScalar(before); }
    bool before;
};

Coded encodeAllWith(const std::vector<std::int32_t>& c, Dims d, int levels, EntropyMode mode, bool scalar) {
    const ScalarEncoder path(scalar);
    const auto layout = sectionLayout(d, levels);
    Coded out;
    out.sections.resize(layout.size());
    for (std::size_t s = 0; s < layout.size(); ++s)
        encodeSection(c, d, layout, s, mode, out.sections[s]);
    return out;
}

// Encodes with the default encoder; dense sections also with the scalar one, which must write the same bytes.
Coded encodeAll(const std::vector<std::int32_t>& c, Dims d, int levels, EntropyMode mode) {
    const Coded coded = encodeAllWith(c, d, levels, mode, false);
    if (mode == EntropyMode::Dense)
        EXPECT_EQ(coded.sections, encodeAllWith(c, d, levels, mode, true).sections)
            << "scalar and SIMD dense encoders differ";
    return coded;
}

std::vector<std::int32_t> decodeAllWith(const Coded& coded, Dims d, int levels, EntropyMode mode,
                                        bool scalar) {
    const ScalarDecoder path(scalar);
    const auto layout = sectionLayout(d, levels);
    // A fill value the decoder must overwrite everywhere.
    std::vector<std::int32_t> out(d.count(), 0x5A5A5A5A);
    for (std::size_t s = 0; s < layout.size(); ++s)
        decodeSection(coded.sections[s], out, d, layout, s, mode, "test");
    return out;
}

// Decodes with both dense decoders (scalar and, where the CPU has it, SIMD), which must agree.
std::vector<std::int32_t> decodeAll(const Coded& coded, Dims d, int levels, EntropyMode mode) {
    const auto scalar = decodeAllWith(coded, d, levels, mode, true);
    const auto simd = decodeAllWith(coded, d, levels, mode, false);
    EXPECT_EQ(scalar, simd) << "scalar and SIMD dense decoders differ";
    return simd;
}

// Checks the round trip and that encoding does not touch its input and is deterministic.
void expectRoundTrip(const std::vector<std::int32_t>& c, Dims d, int levels, EntropyMode mode) {
    const std::vector<std::int32_t> copy = c;
    const Coded a = encodeAll(c, d, levels, mode);
    EXPECT_EQ(c, copy) << "encoder modified its input";
    const Coded b = encodeAll(c, d, levels, mode);
    EXPECT_EQ(a.sections, b.sections) << "encoding is not deterministic";
    const auto decoded = decodeAll(a, d, levels, mode);
    ASSERT_EQ(decoded.size(), c.size());
    std::size_t mismatches = 0;
    for (std::size_t i = 0; i < c.size(); ++i)
        mismatches += decoded[i] != c[i];
    EXPECT_EQ(mismatches, 0u) << "dims " << d.x << "x" << d.y << "x" << d.z << ", " << levels
                              << " levels, mode " << int(mode);
}

// Wavelet-like coefficients: Laplacian magnitudes whose scale varies smoothly in space, plus zero regions.
std::vector<std::int32_t> waveletLike(Dims d, std::uint32_t seed, double scale) {
    std::mt19937 rng(seed);
    std::exponential_distribution<double> expo(1.0);
    std::vector<std::int32_t> c(d.count());
    for (std::size_t z = 0; z < d.z; ++z)
        for (std::size_t y = 0; y < d.y; ++y)
            for (std::size_t x = 0; x < d.x; ++x) {
                const double local =
                    scale * (1.0 + 0.9 * std::sin(0.3 * double(x) + 0.2 * double(y) + 0.1 * double(z)));
                const bool empty = (x + 2 * y + 3 * z) % 11 < 3; // zero patches for the row flags
                const double m = empty ? 0.0 : expo(rng) * local;
                const auto v = static_cast<std::int32_t>(std::min(m, double(kMaxMagnitude)));
                c[(z * d.y + y) * d.x + x] = (rng() & 1) ? -v : v;
            }
    return c;
}

const EntropyMode kModes[] = {EntropyMode::Dense, EntropyMode::Fast};

const Dims kShapes[] = {{1, 1, 1},    {1, 7, 1},   {2, 3, 5},  {5, 1, 3},
                        {16, 16, 16}, {17, 9, 33}, {31, 2, 1}, {64, 40, 24}};

} // namespace

TEST(Entropy, RoundTripWaveletLikeSections) {
    std::uint32_t seed = 1;
    for (EntropyMode mode : kModes)
        for (const Dims& d : kShapes)
            for (int levels : {0, 1, 3, 5})
                for (double scale : {0.3, 4.0, 300.0})
                    expectRoundTrip(waveletLike(d, seed++, scale), d, levels, mode);
}

TEST(Entropy, RoundTripAllZero) {
    for (EntropyMode mode : kModes)
        for (const Dims& d : kShapes)
            for (int levels : {0, 2, 4})
                expectRoundTrip(std::vector<std::int32_t>(d.count(), 0), d, levels, mode);
}

TEST(Entropy, RoundTripSingleNonZero) {
    const Dims d{13, 10, 7};
    for (EntropyMode mode : kModes)
        for (std::int32_t v : {1, -1, 2, -3, 1000, -kMaxMagnitude, kMaxMagnitude})
            for (std::size_t pos : {std::size_t(0), std::size_t(1), std::size_t(500), d.count() - 1}) {
                std::vector<std::int32_t> c(d.count(), 0);
                c[pos] = v;
                expectRoundTrip(c, d, 3, mode);
            }
}

TEST(Entropy, RoundTripExtremeMagnitudes) {
    std::mt19937 rng(7);
    for (EntropyMode mode : kModes)
        for (const Dims& d : {Dims{1, 1, 1}, Dims{9, 8, 7}, Dims{32, 32, 32}}) {
            // Every coefficient at the largest magnitude, random signs.
            std::vector<std::int32_t> c(d.count());
            for (auto& v : c)
                v = (rng() & 1) ? kMaxMagnitude : -kMaxMagnitude;
            expectRoundTrip(c, d, 3, mode);
            // Every bit length 0..30 mixed at random.
            for (auto& v : c) {
                const int n = static_cast<int>(rng() % 31);
                const auto m =
                    n == 0 ? 0 : static_cast<std::int32_t>((1u << (n - 1)) | (rng() & ((1u << (n - 1)) - 1)));
                v = (rng() & 1) ? -m : m;
            }
            expectRoundTrip(c, d, 3, mode);
        }
}

TEST(Entropy, FastModeKeepsAny32BitPattern) {
    // Lossless float volumes send raw bit patterns (NaN, Inf, -0) through the fast coder untransformed.
    // Rows of 7 take the encoder's scalar loop, rows of 40 its 16-wide SSE2 loop and then the scalar tail.
    std::mt19937 rng(3);
    for (const Dims& d : {Dims{7, 5, 3}, Dims{40, 3, 2}}) {
        std::vector<std::int32_t> c(d.count());
        for (auto& v : c)
            v = static_cast<std::int32_t>(rng());
        for (std::size_t i : {std::size_t(0), std::size_t(17), std::size_t(38)}) {
            c[i] = INT32_MIN;
            c[i + 1] = INT32_MAX;
            c[i + 2] = -1;
        }
        expectRoundTrip(c, d, 0, EntropyMode::Fast);
    }
}

TEST(Entropy, DequantisedDecodingEqualsDequantiseRow) {
    // decodeSections with a Dequantiser (the fast decoder fuses unfolding and dequantisation) must give
    // exactly dequantiseRow of the decoded indices, bit for bit, for 1-4 byte planes (|q| <= 2^29).
    std::mt19937 rng(5);
    std::vector<double> steps(1 + 7 * 5);
    for (auto& st : steps)
        st = 0.01 + 3.7 * std::generate_canonical<double, 53>(rng);
    for (EntropyMode mode : kModes)
        for (const Dims& d : {Dims{1, 1, 1}, Dims{17, 9, 33}, Dims{64, 40, 24}})
            for (std::int32_t limit : {1, 100, 40000, 5000000, 1 << 29})
                for (double bias : {0.5, 0.375}) {
                    const int levels = 3;
                    std::vector<std::int32_t> c = waveletLike(d, rng(), 0.05 * limit);
                    for (auto& v : c)
                        v = std::clamp(v, -limit, limit);
                    const Coded coded = encodeAll(c, d, levels, mode);
                    const auto layout = sectionLayout(d, levels);
                    std::vector<std::int32_t> expect = decodeAll(coded, d, levels, mode);
                    const Dequantiser dq{steps, bias};
                    for (const auto& sec : layout)
                        for (const SubbandBox& b : sec)
                            for (std::size_t z = b.z0; z < b.z1; ++z)
                                for (std::size_t y = b.y0; y < b.y1; ++y) {
                                    std::int32_t* row = expect.data() + (z * d.y + y) * d.x + b.x0;
                                    dequantiseRow(row, reinterpret_cast<float*>(row), b.x1 - b.x0, dq.step(b),
                                                  bias);
                                }
                    std::vector<std::int32_t> got(d.count(), 0x5A5A5A5A);
                    const std::vector<std::span<const std::uint8_t>> spans(coded.sections.begin(),
                                                                           coded.sections.end());
                    decodeSections(spans, got, d, layout, mode, "test", &dq);
                    EXPECT_EQ(got, expect)
                        << "mode " << int(mode) << ", limit " << limit << ", bias " << bias;
                }
}

TEST(Entropy, DenseRefusesOutOfRangeMagnitudes) {
    const Dims d{4, 4, 4};
    const auto layout = sectionLayout(d, 0);
    for (std::int32_t v : {kMaxMagnitude + 1, -kMaxMagnitude - 1, INT32_MIN})
        for (const bool scalar : {false, true}) {
            const ScalarEncoder path(scalar);
            std::vector<std::int32_t> c(d.count(), 0);
            c[5] = v;
            std::vector<std::uint8_t> out;
            EXPECT_THROW(encodeSection(c, d, layout, 0, EntropyMode::Dense, out), Error);
        }
}

TEST(Entropy, DenseIsSmallerThanFastOnCorrelatedData) {
    // The dense coder's contexts must pay for themselves on data with spatially varying scale.
    const Dims d{64, 64, 32};
    const auto c = waveletLike(d, 11, 20.0);
    std::size_t dense = 0, fast = 0;
    for (const auto& s : encodeAll(c, d, 3, EntropyMode::Dense).sections)
        dense += s.size();
    for (const auto& s : encodeAll(c, d, 3, EntropyMode::Fast).sections)
        fast += s.size();
    EXPECT_LT(dense, fast);
}

namespace {

// Decodes one damaged section: IoError is the only acceptable failure. Returns true when it was detected.
// Both dense decoders must reach the same verdict and, when they accept the data, the same coefficients.
bool decodeDamaged(const std::vector<std::uint8_t>& bytes, Dims d, int levels, std::size_t s,
                   EntropyMode mode, const std::vector<std::int32_t>& earlier) {
    const auto layout = sectionLayout(d, levels);
    std::vector<std::int32_t> out[2] = {earlier, earlier}; // earlier sections give the parent contexts
    bool detected[2] = {false, false};
    for (int scalar = 0; scalar < 2; ++scalar) {
        const ScalarDecoder path(scalar != 0);
        try {
            decodeSection(bytes, out[scalar], d, layout, s, mode, "fuzz");
        } catch (const IoError&) {
            detected[scalar] = true;
        }
    }
    EXPECT_EQ(detected[0], detected[1]) << "scalar and SIMD dense decoders disagree on damaged data";
    if (!detected[0] && !detected[1]) EXPECT_EQ(out[0], out[1]);
    return detected[0];
}

} // namespace

TEST(Entropy, DamagedSectionsAreRejectedWithoutCrashing) {
    const Dims d{24, 17, 9};
    const int levels = 2;
    const auto c = waveletLike(d, 5, 12.0);
    const auto layout = sectionLayout(d, levels);
    std::mt19937 rng(9);
    for (EntropyMode mode : kModes) {
        const Coded coded = encodeAll(c, d, levels, mode);
        for (std::size_t s = 0; s < layout.size(); ++s) {
            const auto& good = coded.sections[s];
            ASSERT_FALSE(good.empty());
            // Every truncation is detected: each stream's length is implied by its content.
            for (std::size_t len = 0; len < good.size(); ++len) {
                const std::vector<std::uint8_t> cut(good.begin(),
                                                    good.begin() + static_cast<std::ptrdiff_t>(len));
                EXPECT_TRUE(decodeDamaged(cut, d, levels, s, mode, c))
                    << "section " << s << " cut to " << len;
            }
            // An extra byte is detected.
            auto longer = good;
            longer.push_back(0);
            EXPECT_TRUE(decodeDamaged(longer, d, levels, s, mode, c));
            // Bit flips anywhere: never a crash or another exception; most are detected (raw mantissa bits
            // carry no redundancy, the container's checksums catch those).
            std::size_t detected = 0, flips = 0;
            for (std::size_t pos = 0; pos < good.size(); pos += 1 + good.size() / 64)
                for (int bit : {0, 5}) {
                    auto bad = good;
                    bad[pos] ^= static_cast<std::uint8_t>(1u << bit);
                    detected += decodeDamaged(bad, d, levels, s, mode, c);
                    ++flips;
                }
            EXPECT_GT(detected, 0u) << "section " << s;
            EXPECT_LE(detected, flips);
        }
        // Random bytes of many lengths as any section.
        for (int trial = 0; trial < 200; ++trial) {
            std::vector<std::uint8_t> junk(rng() % 300);
            for (auto& b : junk)
                b = static_cast<std::uint8_t>(rng());
            const std::size_t s = rng() % layout.size();
            decodeDamaged(junk, d, levels, s, mode, std::vector<std::int32_t>(d.count(), 0));
        }
    }
}

TEST(Entropy, DispatchUsesTheVectorKernelsTheCpuHas) {
    // The build must hand the AVX-512 tables to the dispatcher wherever they are built: a build setting lost
    // in a move of the files once left every coder on the scalar path, which no other test notices.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    // Both coders' tables come from the same dispatch unit and build setting.
    EXPECT_EQ(denseDecoderSimdAvailable(), entropy::avx512DenseDecoderKernels() != nullptr);
#else
    GTEST_SKIP() << "the AVX-512 coders are built for x86-64 only";
#endif
}

TEST(Entropy, SimdEncoderArithmeticEqualsTheTables) {
    // The SIMD encoder computes by lzcnt arithmetic what the scalar coder looks up: magnitude symbols,
    // the previous symbol's share W of the activity, activity classes (including u32 sums past 2^31).
    EXPECT_TRUE(denseEncoderArithmeticMatchesTables());
}

TEST(Entropy, DenseDecodersAgreeOnEveryLaneCountAndRaggedRows) {
    // Sections of 1..7 subbands (sizes 1 along an axis have no high band there), odd sizes whose low and
    // high bands differ by one column or row, sparse data (many zero rows, so row groups of every size and
    // rows with different non-zero counts), dense data and large magnitudes; decodeAll compares both paths.
    if (!denseDecoderSimdAvailable())
        std::printf("note: no AVX-512 dense decoder on this CPU, scalar only\n");
    std::uint32_t seed = 100;
    std::mt19937 rng(seed);
    for (const Dims& d : {Dims{1, 1, 9}, Dims{1, 7, 5}, Dims{3, 1, 1}, Dims{5, 6, 1}, Dims{7, 1, 6},
                          Dims{2, 2, 2}, Dims{9, 7, 5}, Dims{33, 17, 9}, Dims{64, 3, 5}, Dims{40, 40, 8}})
        for (int levels : {1, 2, 3})
            for (double scale : {0.05, 0.4, 6.0, 5000.0}) {
                auto c = waveletLike(d, seed++, scale);
                for (auto& v : c) // extra zero runs: rows of a group with very different non-zero counts
                    if (rng() % 3 == 0) v = 0;
                expectRoundTrip(c, d, levels, EntropyMode::Dense);
            }
}

namespace {

// A zstd frame holding `raw` in one raw block (frame format, RFC 8878): for sections that the encoder
// would never write.
std::vector<std::uint8_t> rawZstdFrame(const std::vector<std::uint8_t>& raw) {
    std::vector<std::uint8_t> f{0x28, 0xB5, 0x2F, 0xFD, 0x20, static_cast<std::uint8_t>(raw.size())};
    const std::uint32_t blockHeader = 1u | static_cast<std::uint32_t>(raw.size()) << 3; // last, raw
    for (int i = 0; i < 3; ++i)
        f.push_back(static_cast<std::uint8_t>(blockHeader >> (8 * i)));
    f.insert(f.end(), raw.begin(), raw.end());
    return f;
}

} // namespace

TEST(Entropy, FastZeroBlockSkipping) {
    // Mostly-zero sections are sent as a bitmap of non-zero 4-byte blocks plus those blocks (flag 0x80 in
    // the section's first byte), dense ones plainly; both round-trip, and damage to the skip layout is
    // detected or decodes cleanly (never a crash: run under ASan).
    const Dims d{64, 40, 24};
    const int levels = 3;
    std::vector<std::int32_t> c = waveletLike(d, 21, 0.4);
    const auto layout = sectionLayout(d, levels);
    const Coded coded = encodeAll(c, d, levels, EntropyMode::Fast);
    ASSERT_EQ(coded.sections.back()[0], 0x81) << "the finest, mostly zero section skips zero blocks";
    const Coded dense = encodeAll(waveletLike(d, 22, 300.0), d, levels, EntropyMode::Fast);
    EXPECT_EQ(dense.sections.back()[0] & 0x80, 0) << "a section with few zero blocks is sent plainly";
    expectRoundTrip(c, d, levels, EntropyMode::Fast);
    const std::size_t s = layout.size() - 1;
    const auto& good = coded.sections[s];
    for (std::size_t len = 0; len < good.size(); ++len) {
        const std::vector<std::uint8_t> cut(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(len));
        EXPECT_TRUE(decodeDamaged(cut, d, levels, s, EntropyMode::Fast, c)) << "cut to " << len;
    }
    for (std::size_t pos = 0; pos < good.size(); ++pos)
        for (int bit = 0; bit < 8; ++bit) {
            auto bad = good;
            bad[pos] ^= static_cast<std::uint8_t>(1u << bit);
            decodeDamaged(bad, d, levels, s, EntropyMode::Fast, c);
        }
    // Hand-made sections of a 15-coefficient brick (4 blocks, one bitmap byte): the layout's own checks.
    const Dims t{5, 1, 3};
    const auto tl = sectionLayout(t, 0);
    auto decode = [&](const std::vector<std::uint8_t>& raw) {
        std::vector<std::uint8_t> section{0x81};
        const auto frame = rawZstdFrame(raw);
        section.insert(section.end(), frame.begin(), frame.end());
        std::vector<std::int32_t> out(t.count(), 7);
        decodeSection(section, out, t, tl, 0, EntropyMode::Fast, "test");
        return out;
    };
    std::vector<std::int32_t> expect(t.count(), 0);
    expect[4] = 1;   // folded 2 at byte 4: block 1
    expect[14] = -1; // folded 1 at byte 14: block 3
    EXPECT_EQ(decode({0x0A, 2, 0, 0, 0, 0, 0, 1, 0}), expect);
    EXPECT_THROW(decode({0x1A, 2, 0, 0, 0, 0, 0, 1, 0}), IoError) << "bit past the last block";
    EXPECT_THROW(decode({0x0B, 2, 0, 0, 0, 0, 0, 1, 0}), IoError) << "more blocks flagged than sent";
    EXPECT_THROW(decode({0x02, 2, 0, 0, 0, 0, 0, 1, 0}), IoError) << "more blocks sent than flagged";
    EXPECT_THROW(decode({}), IoError) << "no bitmap";
}

TEST(Entropy, EmptySectionMustBeEmpty) {
    // A 1x1x1 brick with 2 levels has empty detail sections; data there is an error.
    const Dims d{1, 1, 1};
    const auto layout = sectionLayout(d, 2);
    ASSERT_EQ(layout.size(), 3u);
    std::vector<std::int32_t> out(1, 0);
    for (EntropyMode mode : kModes) {
        std::vector<std::uint8_t> coded;
        encodeSection(out, d, layout, 1, mode, coded);
        EXPECT_TRUE(coded.empty());
        EXPECT_THROW(decodeSection(std::vector<std::uint8_t>{1}, out, d, layout, 1, mode, "t"), IoError);
    }
}
