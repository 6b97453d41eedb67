// Pre-integration tables: reference against closed forms and brute force, kernels against the reference, hard
// cases.
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "preintegration/PreintegrationTable.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

using namespace volcl;

namespace {

ComputeContext& context() {
    static std::unique_ptr<ComputeContext> cc = std::make_unique<ComputeContext>();
    return *cc;
}

TransferFunction tfFrom(const std::string& json) {
    return TransferFunction::fromJson(json);
}

// The documented example TF (docs/contract.md): ramps, a transparent band, colour and extinction breakpoints that differ.
TransferFunction contractTf() {
    return tfFrom(R"({"domain":[0,255],"color":[[0,0,0,0],[128,1,0.6,0.2],[255,1,1,1]],
                      "extinction":[[0,0],[60,0],[80,0.8],[255,0.05]]})");
}
// Steps in colour and extinction (two points at the same s), and an extinction of 1e4 on a plateau.
TransferFunction stepTf() {
    return tfFrom(
        R"({"domain":[0,255],"color":[[0,0.2,0.4,0.9],[100,0.2,0.4,0.9],[100,1,0.1,0],[255,0.5,1,0.3]],
                      "extinction":[[0,0.05],[90,0.05],[90,2],[150,2],[150,10000],[170,10000],[170,0.3],[255,0.3]]})");
}
// A narrow spike one node wide at N = 256 and a second, narrower than a node.
TransferFunction spikeTf() {
    return tfFrom(R"({"domain":[0,255],"color":[[0,1,1,1],[120,1,0.2,0.1],[121,0.1,1,0.2],[255,0.3,0.3,1]],
                      "extinction":[[0,0],[119,0],[120,50],[121,0],[200,0],[200.2,400],[200.4,0],[255,0]]})");
}
TransferFunction constantTf(double tau, std::array<double, 3> c) {
    std::ostringstream s;
    s << R"({"domain":[0,1],"color":[[0,)" << c[0] << ',' << c[1] << ',' << c[2] << R"(]],"extinction":[[0,)"
      << tau << "]]}";
    return tfFrom(s.str());
}

TableSpec spec2d(int n, double step) {
    TableSpec s;
    s.size = n;
    s.step = step;
    return s;
}
TableSpec spec3d(int n, int lengths, double maxLength, LengthAxis axis = LengthAxis::Linear) {
    TableSpec s;
    s.size = n;
    s.axis = axis;
    s.lengths = lengths;
    s.maxLength = maxLength;
    return s;
}

PreintegrationTable exact(const TransferFunction& tf, const TableSpec& spec,
                          PreintMethod m = PreintMethod::Exact) {
    GeneratorOptions o;
    o.method = m;
    return generatePreintegrationTable(tf, spec, o, &context());
}

// Every entry finite, alpha in [0, 1], rgb in [0, max colour]; the rule for every method.
void expectBounded(const PreintegrationTable& t, double maxColor) {
    std::size_t bad = 0;
    for (std::size_t i = 0; i < t.rgba.size(); i += 4) {
        for (int c = 0; c < 4; ++c) {
            float v = t.rgba[i + c];
            double hi = c == 3 ? 1.0 : maxColor;
            if (!std::isfinite(v) || v < 0.0f || v > hi * (1.0 + 1e-6)) ++bad;
        }
    }
    EXPECT_EQ(bad, 0u) << "entries outside their bounds or not finite (method " << methodName(t.method)
                       << ")";
}

// Independent brute force: front-to-back compositing of `steps` midpoint slabs (converges as 1/steps^2).
std::array<double, 4> bruteForce(const TransferFunction& tf, double sf, double sb, double l, int steps) {
    double dt = l / steps, trans = 1.0;
    std::array<double, 4> acc{0, 0, 0, 0};
    for (int i = 0; i < steps; ++i) {
        double s = sf + (sb - sf) * (i + 0.5) / steps;
        double a = -std::expm1(-tf.extinctionAt(s) * dt);
        auto c = tf.colorAt(s);
        for (int q = 0; q < 3; ++q)
            acc[q] += trans * c[q] * a;
        trans *= 1.0 - a;
    }
    acc[3] = 1.0 - trans;
    return acc;
}

} // namespace

// ------------------------------------------------------------------------------------------ reference

TEST(PreintReference, ConstantTfMatchesClosedForm) {
    auto tf = constantTf(2.5, {0.3, 0.6, 0.9});
    for (double l : {1e-9, 1e-3, 0.1, 1.0, 7.0, 100.0}) {
        for (auto [sf, sb] : {std::pair{0.0, 1.0}, std::pair{0.7, 0.2}, std::pair{0.5, 0.5}}) {
            auto r = referenceSegment(tf, sf, sb, l);
            double alpha = -std::expm1(-2.5 * l);
            EXPECT_NEAR(r[3], alpha, 1e-15 + 1e-13 * alpha);
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(r[c], (0.3 * (c + 1)) * alpha, 1e-15 + 1e-13 * alpha);
        }
    }
}

TEST(PreintReference, LinearColourConstantTauMatchesClosedForm) {
    // c(w) = c_f + (c_b - c_f) w, tau constant: rgb = c_f (1 - e^-k) + dc ((1 - e^-k) / k - e^-k), k = tau l.
    auto tf = tfFrom(R"({"domain":[0,1],"color":[[0,0,0,0],[1,1,0.5,0.25]],"extinction":[[0,3]]})");
    for (double l : {1e-4, 0.2, 1.0, 5.0, 40.0}) {
        double k = 3.0 * l, a = -std::expm1(-k);
        for (auto [sf, sb] : {std::pair{0.0, 1.0}, std::pair{0.9, 0.1}}) {
            auto r = referenceSegment(tf, sf, sb, l);
            double expect = sf * a + (sb - sf) * (a / k - std::exp(-k));
            EXPECT_NEAR(r[0], expect, 1e-14) << "l=" << l << " sf=" << sf;
            EXPECT_NEAR(r[1], 0.5 * expect, 1e-14);
            EXPECT_NEAR(r[3], a, 1e-15);
        }
    }
}

TEST(PreintReference, AgreesWithBruteForceOnStepsAndRamps) {
    for (const auto& tf : {contractTf(), stepTf(), spikeTf()}) {
        for (auto [sf, sb, l] :
             {std::tuple{10.0, 240.0, 1.0}, std::tuple{240.0, 10.0, 1.0}, std::tuple{95.0, 160.0, 0.01},
              std::tuple{70.0, 130.0, 3.0}, std::tuple{199.0, 202.0, 0.5}, std::tuple{130.0, 119.5, 0.2}}) {
            auto r = referenceSegment(tf, sf, sb, l);
            // Midpoint slabs straddling a TF step are first-order accurate: 400k slabs leave ~1e-6 per step.
            auto b = bruteForce(tf, sf, sb, l, 400000);
            for (int c = 0; c < 4; ++c)
                EXPECT_NEAR(r[c], b[c], 1e-5) << "sf=" << sf << " sb=" << sb << " l=" << l;
        }
    }
}

TEST(PreintReference, ZeroAndNegativeLengthGiveZero) {
    auto r = referenceSegment(contractTf(), 10, 200, 0.0);
    for (double v : r)
        EXPECT_EQ(v, 0.0);
}

// ------------------------------------------------------------------------------------------ exact kernel

TEST(PreintExact, MatchesReference2dOnEveryEntry) {
    for (const auto& tf : {contractTf(), stepTf(), spikeTf()}) {
        for (double step : {0.25, 1.0, 4.0}) {
            auto t = exact(tf, spec2d(256, step));
            expectBounded(t, tf.maxColor());
            TableError e = compareWithReference(t, tf);
            std::cout << "[ info ] 2D 256^2 step " << step << ": max |exact - reference| = " << e.maxAbs
                      << '\n';
            EXPECT_EQ(e.entries, 256u * 256u);
            EXPECT_LE(e.maxAbs, 1e-4) << "step " << step << " worst (front " << e.worstFront << ", back "
                                      << e.worstBack << ", channel " << e.worstChannel << ")";
        }
    }
}

TEST(PreintExact, MatchesReference3dOnEveryEntry) {
    for (const auto& tf : {contractTf(), stepTf(), spikeTf()}) {
        auto t = exact(tf, spec3d(256, 12, 6.0));
        expectBounded(t, tf.maxColor());
        TableError e = compareWithReference(t, tf);
        std::cout << "[ info ] 3D 256^2 x 12: max |exact - reference| = " << e.maxAbs << '\n';
        EXPECT_EQ(e.entries, 256u * 256u * 12u);
        EXPECT_LE(e.maxAbs, 1e-4) << "worst slice " << e.worstK << " (front " << e.worstFront << ", back "
                                  << e.worstBack << ")";
    }
}

TEST(PreintExact, ExponentialLengthAxisMatchesReference) {
    auto spec = spec3d(64, 20, 8.0, LengthAxis::Exponential);
    auto lengths = spec.lengthValues();
    ASSERT_EQ(lengths.size(), 20u);
    EXPECT_DOUBLE_EQ(lengths.back(), 8.0);
    for (std::size_t k = 1; k < lengths.size(); ++k)
        EXPECT_GT(lengths[k], lengths[k - 1]);
    // l' = 1 - 2^-l is evenly spaced.
    double d0 = -std::expm1(-lengths[0] * std::log(2.0));
    double d1 = -std::expm1(-lengths[1] * std::log(2.0)) - d0;
    EXPECT_NEAR(d0, d1, 1e-12);
    auto tf = stepTf();
    auto t = exact(tf, spec);
    EXPECT_LE(compareWithReference(t, tf).maxAbs, 1e-4);
}

TEST(PreintExact, DoublePrecisionMatchesReferenceCloser) {
    if (!context().device().fp64) GTEST_SKIP() << "device has no fp64";
    auto tf = contractTf();
    GeneratorOptions o;
    o.precision = Precision::Double;
    o.maxSubstepDepth = 0.25;
    auto t = generatePreintegrationTable(tf, spec2d(128, 2.0), o, &context());
    EXPECT_LE(compareWithReference(t, tf).maxAbs, 2e-6);
}

// ------------------------------------------------------------------------------------------ hard cases

TEST(PreintHardCases, DiagonalOfConstantTfIsClosedForm) {
    for (double tau : {0.0, 1e-3, 1.0, 1e3, 1e6}) {
        auto tf = constantTf(tau, {0.2, 0.5, 1.0});
        auto t = exact(tf, spec3d(16, 8, 3.0));
        for (int k = 0; k < 8; ++k) {
            double l = t.lengthValues[k], a = -std::expm1(-tau * l);
            for (int i = 0; i < 16; ++i) {
                auto e = t.entry(k, i, (i * 7) % 16); // constant TF: every pair behaves like the diagonal
                EXPECT_NEAR(e[3], a, 1e-6);
                EXPECT_NEAR(e[2], a, 1e-5);
                EXPECT_NEAR(e[0], 0.2 * a, 1e-5);
            }
        }
    }
}

TEST(PreintHardCases, ShortLengthsGoToZero) {
    auto tf = stepTf();
    for (double l : {1e-7, 1e-5, 1e-3}) {
        auto t = exact(tf, spec2d(64, l));
        expectBounded(t, tf.maxColor());
        float worst = 0.0f;
        for (float v : t.rgba)
            worst = std::max(worst, v);
        // Bounded by max tau * l (opacity) and max colour * max tau * l (colour): both tiny, never NaN.
        EXPECT_LE(worst, 1e4 * l * 1.0001 + 1e-6) << "l=" << l;
        EXPECT_LE(compareWithReference(t, tf).maxAbs, 1e-5);
    }
}

TEST(PreintHardCases, HugeLengthAndExtinctionSaturate) {
    auto tf = tfFrom(
        R"({"domain":[0,1],"color":[[0,0.1,0.2,0.3],[1,0.9,0.8,0.7]],"extinction":[[0,1e6],[1,1e6]]})");
    auto t = exact(tf, spec3d(32, 4, 1e6));
    expectBounded(t, tf.maxColor());
    for (std::size_t i = 0; i < t.rgba.size(); i += 4)
        EXPECT_EQ(t.rgba[i + 3], 1.0f);
    // Opaque at once: the colour is the front colour.
    auto e = t.entry(3, 0, 31);
    EXPECT_NEAR(e[0], 0.1, 1e-4);
    EXPECT_LE(compareWithReference(t, tf).maxAbs, 1e-4);
}

// Lengths far beyond any volume: every absorbing segment saturates, and the tables must still match the
// reference (the kernels once took work growing with the length: 1e20 did not finish). Both precisions,
// 3D (linear and exponential axes) and 2D, on the contract example TF (extinction rising from zero) and on steps.
TEST(PreintHardCases, HugeLengthsSaturateAndMatchTheReference) {
    for (const TransferFunction& tf : {contractTf(), stepTf(), spikeTf()}) {
        for (double len : {1e12, 1e20, 1e30}) {
            for (Precision p : {Precision::Float, Precision::Double}) {
                GeneratorOptions o;
                o.precision = p;
                for (const TableSpec& spec :
                     {spec3d(16, 2, len), spec3d(16, 3, len, LengthAxis::Exponential), spec2d(64, len)}) {
                    const auto t = generatePreintegrationTable(tf, spec, o, &context());
                    expectBounded(t, tf.maxColor());
                    EXPECT_LE(compareWithReference(t, tf, 4000).maxAbs, 1e-4)
                        << "length " << len << (p == Precision::Float ? " float" : " double") << " axis "
                        << lengthAxisName(spec.axis);
                }
            }
        }
    }
}

TEST(PreintHardCases, ExtinctionFromZeroToMillion) {
    for (double tau : {0.0, 1e-6, 1e-2, 1.0, 1e2, 1e4, 1e6}) {
        std::ostringstream s;
        s << R"({"domain":[0,255],"color":[[0,1,0,0],[255,0,0,1]],"extinction":[[0,0],[100,)" << tau
          << R"(],[101,0],[255,)" << tau / 2 << "]]}";
        auto tf = tfFrom(s.str());
        auto t = exact(tf, spec3d(128, 4, 2.0));
        expectBounded(t, tf.maxColor());
        EXPECT_LE(compareWithReference(t, tf).maxAbs, 1e-4) << "tau " << tau;
    }
}

TEST(PreintHardCases, ZeroExtinctionEverywhereGivesZero) {
    auto tf = tfFrom(R"({"domain":[0,10],"color":[[0,1,1,1],[10,0.5,0,1]],"extinction":[[0,0]]})");
    for (PreintMethod m : {PreintMethod::Exact, PreintMethod::Incremental, PreintMethod::IntegralFunction,
                           PreintMethod::Roettger2d, PreintMethod::Polynomial}) {
        auto t = exact(tf, spec3d(33, 5, 10.0), m);
        for (float v : t.rgba)
            ASSERT_EQ(v, 0.0f) << methodName(m);
    }
}

TEST(PreintHardCases, SizesFromTwoTo4096) {
    auto tf = contractTf();
    for (int n : {2, 3, 17, 100, 4096}) {
        auto t = exact(tf, spec2d(n, 1.5));
        expectBounded(t, tf.maxColor());
        TableError e = compareWithReference(t, tf, n > 512 ? 50000 : 0);
        EXPECT_LE(e.maxAbs, 1e-4) << "N=" << n;
    }
}

TEST(PreintHardCases, InvalidSpecsAreRefused) {
    auto tf = contractTf();
    EXPECT_THROW(exact(tf, spec2d(1, 1.0)), UsageError);
    EXPECT_THROW(exact(tf, spec2d(64, 0.0)), UsageError);
    EXPECT_THROW(exact(tf, spec2d(64, -1.0)), UsageError);
    EXPECT_THROW(exact(tf, spec2d(64, std::nan(""))), UsageError);
    EXPECT_THROW(exact(tf, spec2d(64, INFINITY)), UsageError);
    EXPECT_THROW(exact(tf, spec2d(64, 1e300)), UsageError); // beyond what the EXR attributes hold
    EXPECT_THROW(exact(tf, spec3d(64, 4, 1e300)), UsageError);
    EXPECT_THROW(exact(tf, spec3d(64, 0, 1.0)), UsageError);
    EXPECT_THROW(exact(tf, spec3d(64, 4, 0.0)), UsageError);
    EXPECT_THROW(exact(tf, spec3d(65536, 4, 1.0)), UsageError);
    EXPECT_THROW(exact(tf, spec3d(64, 4, 1.0, LengthAxis::Exponential), PreintMethod::Incremental),
                 UsageError);
    EXPECT_THROW(parseMethod("fast"), UsageError);
    GeneratorOptions o;
    o.maxSubstepDepth = 0.0;
    EXPECT_THROW(generatePreintegrationTable(tf, spec2d(8, 1.0), o, &context()), UsageError);
    o.maxSubstepDepth = 1e-9; // would mean 5e10 sub-pieces per TF piece
    EXPECT_THROW(generatePreintegrationTable(tf, spec2d(8, 1.0), o, &context()), UsageError);
    o = {};
    EXPECT_THROW(generatePreintegrationTable(tf, spec2d(8, 1.0), o, nullptr), UsageError);
}

TEST(PreintHardCases, AlphaIsSymmetricAndMonotoneInLength) {
    auto tf = stepTf();
    auto t = exact(tf, spec3d(96, 16, 3.0));
    double worstSym = 0.0;
    int nonMonotone = 0;
    for (int k = 0; k < 16; ++k)
        for (int i = 0; i < 96; ++i)
            for (int j = 0; j < 96; ++j) {
                // The optical depth does not depend on the direction of travel.
                worstSym = std::max(worstSym, double(std::abs(t.entry(k, i, j)[3] - t.entry(k, j, i)[3])));
                if (k > 0 && t.entry(k, i, j)[3] < t.entry(k - 1, i, j)[3]) ++nonMonotone;
            }
    EXPECT_LE(worstSym, 1e-6);
    EXPECT_EQ(nonMonotone, 0);
}

TEST(PreintHardCases, ConstantColourGivesColourTimesAlpha) {
    // With one colour everywhere, rgb = c * alpha for any extinction profile (and so is symmetric).
    auto tf = tfFrom(R"({"domain":[0,255],"color":[[0,0.25,0.5,1]],
                         "extinction":[[0,0],[50,3],[50,0.1],[180,40],[200,0]]})");
    auto t = exact(tf, spec2d(128, 2.0));
    double worst = 0.0;
    for (int i = 0; i < 128; ++i)
        for (int j = 0; j < 128; ++j) {
            auto e = t.entry(0, i, j);
            worst = std::max(worst, double(std::abs(e[1] - 0.5f * e[3])));
            worst = std::max(worst, double(std::abs(e[1] - t.entry(0, j, i)[1])));
        }
    EXPECT_LE(worst, 2e-6);
}

// ------------------------------------------------------------------------------------------ other methods

TEST(PreintMethods, EveryMethodIsBoundedAndErrorsAreAsDocumented) {
    auto tf = contractTf();
    auto spec = spec3d(64, 16, 4.0);
    auto ex = exact(tf, spec);
    for (PreintMethod m : {PreintMethod::Incremental, PreintMethod::IntegralFunction,
                           PreintMethod::Roettger2d, PreintMethod::Polynomial}) {
        auto t = exact(tf, spec, m);
        expectBounded(t, tf.maxColor());
        TableError e = compareWithReference(t, tf);
        // The approximations are worse than exact but not garbage on this smooth TF.
        EXPECT_LE(e.maxAbs, 0.7) << methodName(m);
        EXPECT_GT(e.maxAbs, compareWithReference(ex, tf).maxAbs) << methodName(m);
    }
}

TEST(PreintMethods, IncrementalFirstSliceIsExactAndRecursionIsClose) {
    auto tf = contractTf();
    auto t = exact(tf, spec3d(128, 32, 2.0), PreintMethod::Incremental);
    auto ex = exact(tf, spec3d(128, 32, 2.0));
    // Slice 0 is the exact kernel (scalar form here, vector form in `ex`: equal up to float rounding).
    for (int i = 0; i < 128; i += 7)
        for (int j = 0; j < 128; j += 5)
            for (int c = 0; c < 4; ++c)
                EXPECT_NEAR(t.entry(0, i, j)[c], ex.entry(0, i, j)[c], 1e-6);
    EXPECT_LE(compareWithReference(t, tf).maxAbs, 0.05);
}

TEST(PreintMethods, IntegralFunctionIsExactWithoutSelfAttenuation) {
    // For short segments self-attenuation vanishes and Engel's table converges to the reference.
    auto tf = contractTf();
    auto t = exact(tf, spec2d(128, 1e-3), PreintMethod::IntegralFunction);
    EXPECT_LE(compareWithReference(t, tf).maxAbs, 1e-6);
    auto longer = exact(tf, spec2d(128, 8.0), PreintMethod::IntegralFunction);
    EXPECT_GT(compareWithReference(longer, tf).maxAbs, 1e-2);
}

TEST(PreintMethods, Roettger2dIsExactAtTheMeanLength) {
    auto tf = stepTf();
    auto spec = spec3d(64, 3, 3.0); // lengths 1, 2, 3: the mean is the middle slice
    auto t = exact(tf, spec, PreintMethod::Roettger2d);
    auto ex = exact(tf, spec);
    for (int i = 0; i < 64; ++i)
        for (int j = 0; j < 64; ++j)
            for (int c = 0; c < 4; ++c)
                EXPECT_NEAR(t.entry(1, i, j)[c], ex.entry(1, i, j)[c], 1e-6);
}

TEST(PreintMethods, PolynomialAlphaIsExactAndHigherDegreeHelps) {
    auto tf = contractTf();
    auto spec = spec3d(64, 32, 6.0);
    GeneratorOptions o;
    o.method = PreintMethod::Polynomial;
    o.polynomialDegree = 1;
    auto p1 = generatePreintegrationTable(tf, spec, o, &context());
    o.polynomialDegree = 4;
    auto p4 = generatePreintegrationTable(tf, spec, o, &context());
    auto ex = exact(tf, spec);
    double alphaErr = 0.0;
    for (std::size_t i = 3; i < ex.rgba.size(); i += 4)
        alphaErr = std::max(alphaErr, double(std::abs(p4.rgba[i] - ex.rgba[i])));
    EXPECT_LE(alphaErr, 1e-5);
    EXPECT_LT(compareWithReference(p4, tf).maxAbs, compareWithReference(p1, tf).maxAbs);
}

// ------------------------------------------------------------------------------------------ files

TEST(PreintFiles, ExrRoundTripKeepsEntriesAndAttributes) {
    std::filesystem::create_directories(VOLCL_TEST_TMP_DIR);
    auto tf = stepTf();
    for (auto spec : {spec2d(32, 0.75), spec3d(16, 5, 2.5, LengthAxis::Exponential)}) {
        auto t = exact(tf, spec);
        auto path = std::filesystem::path(VOLCL_TEST_TMP_DIR) / "preint_roundtrip.exr";
        t.writeExr(path);
        auto r = PreintegrationTable::readExr(path);
        EXPECT_EQ(r.rgba, t.rgba);
        EXPECT_EQ(r.spec.axis, spec.axis);
        EXPECT_EQ(r.size(), spec.size);
        EXPECT_EQ(r.sliceCount(), t.sliceCount());
        EXPECT_EQ(r.method, PreintMethod::Exact);
        EXPECT_EQ(r.domain[1], 255.0);
        auto back = TransferFunction::fromJson(r.tfJson);
        EXPECT_EQ(back.breakpoints(), tf.breakpoints());
        auto img = t.toImage();
        EXPECT_EQ(img.width, spec.size);
        EXPECT_EQ(img.height, spec.size * t.sliceCount());
        std::filesystem::remove(path);
    }
}

TEST(PreintFiles, HalfFloatTablesStayWithinHalfPrecision) {
    std::filesystem::create_directories(VOLCL_TEST_TMP_DIR);
    auto tf = contractTf();
    auto t = exact(tf, spec2d(64, 1.0));
    auto path = std::filesystem::path(VOLCL_TEST_TMP_DIR) / "preint_half.exr";
    t.writeExr(path, true);
    auto r = PreintegrationTable::readExr(path);
    for (std::size_t i = 0; i < t.rgba.size(); ++i)
        EXPECT_NEAR(r.rgba[i], t.rgba[i], 1e-3 * t.rgba[i] + 1e-7);
    std::filesystem::remove(path);
}

TEST(PreintFiles, ImagesThatAreNotTablesAreRefused) {
    ImageBuffer img(8, 8, {"R", "G", "B", "A"});
    EXPECT_THROW(PreintegrationTable::fromImage(img, "x.exr"), IoError);
    img.attributes.push_back({"volcl:domain", std::array<float, 2>{0, 1}});
    img.attributes.push_back({"volcl:method", std::string("exact")});
    img.attributes.push_back({"volcl:lengths", 3}); // 3 slices need height 24
    img.attributes.push_back({"volcl:maxLength", 1.0f});
    EXPECT_THROW(PreintegrationTable::fromImage(img, "x.exr"), IoError);
    img.attributes[1].value = std::string("magic");
    EXPECT_THROW(PreintegrationTable::fromImage(img, "x.exr"), IoError);
}

// ------------------------------------------------------------------------------------------ iso and lighting

TEST(PreintIso, HeavisideLimitCompositesCrossedSurfaces) {
    std::vector<IsoSurface> iso{{50.0, {0.5, 0.0, 0.0, 0.5}}, {200.0, {0.0, 0.0, 1.0, 1.0}}};
    auto img = isoSurfaceTableImage(iso, {0.0, 255.0}, 256);
    auto at = [&](int f, int b) {
        return std::array<float, 4>{img.at(b, f, 0), img.at(b, f, 1), img.at(b, f, 2), img.at(b, f, 3)};
    };
    EXPECT_EQ(at(10, 40)[3], 0.0f); // crosses nothing
    EXPECT_EQ(at(60, 60)[3], 0.0f); // diagonal never crosses
    EXPECT_EQ(at(49, 50)[3], 0.5f); // reaches the value: crossed once
    EXPECT_EQ(at(50, 51)[3], 0.0f); // starts on it going up: counted by the previous segment
    auto both = at(0, 255);         // front surface first: 0.5 red, then half of the blue
    EXPECT_FLOAT_EQ(both[0], 0.5f);
    EXPECT_FLOAT_EQ(both[2], 0.5f);
    EXPECT_FLOAT_EQ(both[3], 1.0f);
    auto down = at(255, 0); // blue surface is in front going down and opaque
    EXPECT_FLOAT_EQ(down[0], 0.0f);
    EXPECT_FLOAT_EQ(down[2], 1.0f);
    EXPECT_THROW(isoSurfaceTableImage({{1.0, {1.0, 0.0, 0.0, 0.5}}}, {0.0, 1.0}, 8), DataError);
}

TEST(PreintLighting, DiffuseWeightsSplitTheColourAndMatchClosedForm) {
    auto tf = constantTf(2.0, {1.0, 0.5, 0.25});
    double l = 1.5, k = 2.0 * l;
    auto e = referenceLighting(tf, 0.0, 1.0, l);
    double a = -std::expm1(-k);
    // int_0^1 w k e^{-k w} dw = (1 - e^-k (1 + k)) / k; omega* = that / alpha.
    double back = (1.0 - std::exp(-k) * (1.0 + k)) / k;
    EXPECT_NEAR(e.diffuseBack[0], back, 1e-12);
    EXPECT_NEAR(e.diffuseFront[0] + e.diffuseBack[0], a, 1e-12);
    EXPECT_NEAR(e.omegaStar, back / a, 1e-12);
    auto tiny = referenceLighting(tf, 0.0, 1.0, 1e-9);
    EXPECT_NEAR(tiny.omegaStar, 0.5, 1e-6);
    auto img = lightingTableImage(contractTf(), 16, 1.0);
    EXPECT_EQ(img.channelCount(), 11);
    for (float v : img.pixels)
        EXPECT_TRUE(std::isfinite(v));
}

// ------------------------------------------------------------------------------------------ real data

TEST(PreintRealData, HydrogenAtomSegmentsMatchReference) {
    // Every (s_f, s_b) pair of neighbouring voxels in a real 8-bit volume is a table node pair at
    // N = 256 over [0, 255]: the table must reproduce the reference for the segments a renderer meets.
    std::filesystem::path p = std::filesystem::path(VOLCL_SHARED_DATA_DIR) / "regular" / "hydrogenatom.raw";
    if (!std::filesystem::exists(p)) GTEST_SKIP() << "shared data not found: " << p;
    auto bytes = readFileBytes(p);
    ASSERT_EQ(bytes.size(), 128u * 128u * 128u);
    auto tf = tfFrom(R"({"domain":[0,255],"color":[[0,0,0,0],[20,0.1,0.3,1],[80,1,0.8,0.2],[255,1,1,1]],
                         "extinction":[[0,0],[10,0],[12,0.5],[80,4],[80,20],[255,20]]})");
    auto t = exact(tf, spec2d(256, 1.0));
    std::vector<char> seen(256 * 256, 0);
    double worst = 0.0;
    std::size_t pairs = 0;
    // Neighbours along x, y and z: the segments a ray marcher with step 1 meets along the axes.
    for (std::size_t stride : {std::size_t(1), std::size_t(128), std::size_t(128 * 128)}) {
        for (std::size_t i = 0; i + stride < bytes.size(); ++i) {
            if (stride == 1 && (i + 1) % 128 == 0) continue;
            int f = static_cast<int>(bytes[i]), b = static_cast<int>(bytes[i + stride]);
            if (seen[f * 256 + b]) continue;
            seen[f * 256 + b] = 1;
            ++pairs;
            auto r = referenceSegment(tf, f, b, 1.0);
            auto e = t.entry(0, f, b);
            for (int c = 0; c < 4; ++c)
                worst = std::max(worst, std::abs(double(e[c]) - r[c]));
        }
    }
    EXPECT_GT(pairs, 800u);
    EXPECT_LE(worst, 1e-4);
}
