// Label maps: the grid kernel against its double reference and against fine-step point sampling of an analytic
// label scene (two touching spheres in a ramp), on label grids shifted, anisotropic and rotated; hard cases
// (empty, one voxel, labels 0 and 255, all hidden), label tables and refusals.
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/tf/LabelTable.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/EffectPlan.hpp"
#include "render/Scene.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/grid/LabelField.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::makeFloatVolume;
using volcl::test::maxAbsDiff;
using volcl::test::orthoScene;
using volcl::test::tempDir;
using volcl::test::writeFile;

const Dims kDims{33, 33, 33};

/// The analytic scene: two spheres touching at x = 16.3 (labels 1 and 2) inside a ramp along x.
struct Sphere {
    Vec3 c;
    double r;
};
const Sphere kA{{10.1, 16.2, 16.0}, 6.2}, kB{{22.1, 16.2, 16.0}, 5.8};

int analyticLabel(const Vec3& x) {
    auto inside = [&](const Sphere& s) {
        const Vec3 d = sub(x, s.c);
        return dot(d, d) <= s.r * s.r;
    };
    return inside(kA) ? 1 : inside(kB) ? 2 : 0;
}

/// The intensity ramp v = x / 32 and its TF: colour (0.2, 0.4, 0.9), extinction 0.02 + 0.04 v per unit.
Volume ramp() {
    return makeFloatVolume(kDims, [](double x, double, double) { return x / 32.0; });
}
TransferFunction rampTf() {
    TransferFunction tf;
    tf.domain = {0.0, 1.0};
    tf.color = {{0.0, {0.2, 0.4, 0.9}}};
    tf.extinction = {{0.0, 0.02}, {1.0, 0.06}};
    return tf;
}

/// The label table: label 1 red at opacity 0.1 per unit, label 2 green at 0.15.
LabelTable sphereTable() {
    return LabelTable::fromJson(R"({"labels": [{"label": 1, "color": [1, 0.1, 0.1], "opacity": 0.1},
                                               {"label": 2, "color": [0.1, 1, 0.1], "opacity": 0.15}]})",
                                "spheres");
}

/// A label volume on a grid of its own (origin, spacing, direction) voxelising the analytic labels at its nodes.
Volume voxelisedLabels(Dims d, const Vec3& origin, const Vec3& spacing, const Direction3& dir) {
    Volume v(d, ScalarType::UInt8);
    v.origin = origin;
    v.spacing = spacing;
    v.direction = dir;
    auto vals = v.values<std::uint8_t>();
    for (std::size_t k = 0; k < d.z; ++k)
        for (std::size_t j = 0; j < d.y; ++j)
            for (std::size_t i = 0; i < d.x; ++i) {
                const Vec3 a{double(i) * spacing[0], double(j) * spacing[1], double(k) * spacing[2]};
                Vec3 w = origin;
                for (int r = 0; r < 3; ++r)
                    for (int c = 0; c < 3; ++c)
                        w[std::size_t(r)] += dir[std::size_t(r * 3 + c)] * a[std::size_t(c)];
                vals[v.index(i, j, k)] = std::uint8_t(analyticLabel(w));
            }
    return v;
}

/// Writes `v` (and the table as JSON when given) and returns the scene's label layer.
LabelLayer writeLayer(const Volume& v, const std::string& name, LabelMode mode,
                      const std::string& tableJson = {}) {
    // One folder per test and layer: tempDir() empties its folder, and ctest runs the tests in parallel.
    const auto dir = tempDir(std::string("labels_") +
                             ::testing::UnitTest::GetInstance()->current_test_info()->name() + "_" + name);
    LabelLayer l;
    l.file = dir / (name + ".nrrd");
    writeVolumeFile(v, l.file);
    if (!tableJson.empty()) {
        l.table = dir / (name + ".json");
        writeFile(l.table, tableJson);
    }
    l.mode = mode;
    return l;
}

const char* kSphereTableJson = R"({"labels": [{"label": 1, "color": [1, 0.1, 0.1], "opacity": 0.1},
                                             {"label": 2, "color": [0.1, 1, 0.1], "opacity": 0.15}]})";

Scene sphereScene(int w) {
    return volcl::test::obliqueOrthoScene(kDims, 34.0, w, w, {-20.0, 12.0, -45.0}, 0.1);
}

/// The oracle: fine-step point sampling (step 0.01) of the analytic labels and the ramp along each pixel's ray
/// inside the volume box, classified by the mode's rule on the exact label (no grid at all).
ImageBuffer analyticOracle(const Scene& s, LabelMode mode) {
    const LabelTable table = sphereTable();
    ImageBuffer img(s.width, s.height, {"R", "G", "B", "A"});
    const double h = 0.01;
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x) {
            const CameraRay ray = cameraRay(*s.camera, s.width, s.height, x, y);
            double t0 = 0.0, t1 = 1e30;
            for (int a = 0; a < 3; ++a) {
                const double o = ray.origin[std::size_t(a)], d = ray.direction[std::size_t(a)];
                if (d == 0.0) continue;
                double u0 = (0.0 - o) / d, u1 = (32.0 - o) / d;
                if (u0 > u1) std::swap(u0, u1);
                t0 = std::max(t0, u0);
                t1 = std::min(t1, u1);
            }
            Vec3 rgb{0, 0, 0};
            double T = 1.0;
            for (double t = t0 + 0.5 * h; t < t1; t += h) {
                const Vec3 p = add(ray.origin, scale(ray.direction, t));
                const int l = analyticLabel(p);
                const double v = p[0] / 32.0;
                std::array<double, 4> e{0.2, 0.4, 0.9, 0.02 + 0.04 * v};
                if (l != 0) {
                    const LabelEntry le = table.entry(l);
                    const double tau = -std::log1p(-le.opacity);
                    e = mode == LabelMode::Modulate
                            ? std::array<double, 4>{e[0] * le.rgb[0], e[1] * le.rgb[1], e[2] * le.rgb[2],
                                                    e[3] * le.opacity}
                            : std::array<double, 4>{le.rgb[0], le.rgb[1], le.rgb[2], tau};
                } else if (mode == LabelMode::Alone) {
                    e = {0, 0, 0, 0};
                }
                const double a = -std::expm1(-e[3] * h);
                rgb = add(rgb, scale(Vec3{e[0], e[1], e[2]}, T * a));
                T *= 1.0 - a;
            }
            img.at(x, y, 0) = float(rgb[0]);
            img.at(x, y, 1) = float(rgb[1]);
            img.at(x, y, 2) = float(rgb[2]);
            img.at(x, y, 3) = float(1.0 - T);
        }
    return img;
}

double meanAbsDiff(const ImageBuffer& a, const ImageBuffer& b) {
    double sum = 0.0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = 0; c < 4; ++c)
                sum += std::abs(double(a.at(x, y, c)) - double(b.at(x, y, c)));
    return sum / (4.0 * a.width * a.height);
}

struct LabelGrid {
    const char* name;
    Dims dims;
    Vec3 origin, spacing;
    Direction3 direction;
};

const double kC = std::cos(0.5), kS = std::sin(0.5);
const std::vector<LabelGrid> kGrids = {
    {"same grid", kDims, {0, 0, 0}, {1, 1, 1}, kIdentityDirection},
    {"shifted, anisotropic", {49, 27, 38}, {-0.35, 0.4, -0.2}, {0.7, 1.3, 0.9}, kIdentityDirection},
    // Rotated 0.5 rad about z around a corner outside the box, so it still covers [0, 32]^3.
    {"rotated, anisotropic",
     {60, 60, 40},
     {8.0, -10.0, -0.5},
     {0.8, 0.9, 0.85},
     {kC, -kS, 0, kS, kC, 0, 0, 0, 1}},
};

// The kernel against the double reference of the same classification: every mode and both boundaries, on
// each label grid.
TEST(Labels, KernelMatchesItsReferenceOnEveryGridAndMode) {
    const Volume v = ramp();
    const TransferFunction tf = rampTf();
    for (const LabelGrid& g : kGrids)
        for (LabelMode mode : {LabelMode::Replace, LabelMode::Modulate, LabelMode::Alone})
            for (bool nearest : {false, true}) {
                SCOPED_TRACE(std::string(g.name) + ", " + std::string(labelModeName(mode)) +
                             (nearest ? ", nearest" : ", smooth"));
                // Both at step 0.05: the kernel's samples sit at fixed steps from the entry, the reference's at
                // midpoints of the span divided evenly, and a nearest label (or the colour switch between two
                // labels) is a step in the field, whose sampling error is of the order of the step.
                Scene s = sphereScene(24);
                s.step = 0.05;
                s.labels = writeLayer(voxelisedLabels(g.dims, g.origin, g.spacing, g.direction), "spheres",
                                      mode, kSphereTableJson);
                s.labels->nearest = nearest;
                GridRenderer r(computeContext(), v, tf, s);
                const ImageBuffer img = r.render();
                const ImageBuffer ref = referenceRender(v, tf, s, {.step = 0.05});
                EXPECT_LE(maxAbsDiff(img, ref), 0.02);
                EXPECT_LE(meanAbsDiff(img, ref), 1e-3);
            }
}

// Against the analytic scene: the smooth boundary comes closer than the nearest label voxel's staircase, on
// every label grid.
TEST(Labels, SmoothBoundaryIsCloserToTheAnalyticScene) {
    const Volume v = ramp();
    const TransferFunction tf = rampTf();
    for (const LabelGrid& g : kGrids)
        for (LabelMode mode : {LabelMode::Replace, LabelMode::Modulate, LabelMode::Alone}) {
            SCOPED_TRACE(std::string(g.name) + ", " + std::string(labelModeName(mode)));
            Scene s = sphereScene(40);
            const ImageBuffer oracle = analyticOracle(s, mode);
            s.labels = writeLayer(voxelisedLabels(g.dims, g.origin, g.spacing, g.direction), "spheres", mode,
                                  kSphereTableJson);
            double err[2];
            for (int nearest = 0; nearest < 2; ++nearest) {
                s.labels->nearest = nearest != 0;
                GridRenderer r(computeContext(), v, tf, s);
                err[nearest] = meanAbsDiff(r.render(), oracle);
            }
            std::cout << g.name << " " << labelModeName(mode) << ": mean |error| smooth " << err[0]
                      << ", nearest " << err[1] << "\n";
            EXPECT_LE(err[0], 0.01);
            EXPECT_LT(err[0], err[1]);
        }
}

// The tiny case Oclgrind runs (tests/oclgrind/run_kernels.sh): a 7^3 ramp, labels 1, 2 and 255 on a shifted,
// anisotropic grid and on the same grid, smooth and nearest, 6 x 6 pixels.
TEST(Labels, TinyCaseMatchesItsReference) {
    const Dims n{7, 7, 7};
    const Volume v = makeFloatVolume(n, [](double x, double, double) { return x / 6.0; });
    const TransferFunction tf = rampTf();
    for (bool same : {true, false})
        for (bool nearest : {false, true}) {
            SCOPED_TRACE(std::string(same ? "same grid" : "other grid") +
                         (nearest ? ", nearest" : ", smooth"));
            Volume labels(same ? n : Dims{6, 9, 5}, ScalarType::UInt8);
            if (!same) {
                labels.origin = {0.3, -0.5, 0.2};
                labels.spacing = {1.2, 0.8, 1.4};
            }
            auto vals = labels.values<std::uint8_t>();
            for (std::size_t i = 0; i < vals.size(); ++i)
                vals[i] = std::uint8_t(i % 5 == 0 ? 1 : i % 7 == 0 ? 2 : i % 11 == 0 ? 255 : 0);
            Scene s = orthoScene(n, 8.0, 6, 6);
            s.camera->eye = {0.5, 9.0, -20.0};
            s.step = 0.1;
            s.skipping = SkipMode::Off;
            // Opacities below 1: an opaque label's first sample decides the colour, which the reference's
            // sample positions (the span divided evenly) would not share with the kernel's.
            s.labels = writeLayer(labels, "tiny", nearest ? LabelMode::Alone : LabelMode::Replace,
                                  R"({"labels": [{"label": 1, "color": [1, 0.1, 0.1], "opacity": 0.1},
                                                 {"label": 2, "color": [0.1, 1, 0.1], "opacity": 0.15},
                                                 {"label": 255, "color": [1, 1, 0], "opacity": 0.3}]})");
            s.labels->nearest = nearest;
            const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
            EXPECT_LE(maxAbsDiff(img, referenceRender(v, tf, s, {.step = 0.1})), 0.03);
        }
}

/// A same-grid uint8 label volume with `set` labels.
Volume labelsOnGrid(const std::function<int(std::size_t, std::size_t, std::size_t)>& set) {
    Volume v(kDims, ScalarType::UInt8);
    auto vals = v.values<std::uint8_t>();
    for (std::size_t k = 0; k < kDims.z; ++k)
        for (std::size_t j = 0; j < kDims.y; ++j)
            for (std::size_t i = 0; i < kDims.x; ++i)
                vals[v.index(i, j, k)] = std::uint8_t(set(i, j, k));
    return v;
}

bool allFiniteAndBounded(const ImageBuffer& img) {
    for (float p : img.pixels)
        if (!std::isfinite(p) || p < 0.0f || p > 1.0f + 1e-5f) return false;
    return true;
}

TEST(Labels, EmptyLabelVolumeShowsNothingAloneAndTheTfOtherwise) {
    const Volume v = ramp();
    const TransferFunction tf = rampTf();
    Scene plain = sphereScene(16);
    const ImageBuffer withoutLabels = GridRenderer(computeContext(), v, tf, plain).render();
    for (LabelMode mode : {LabelMode::Replace, LabelMode::Modulate, LabelMode::Alone}) {
        SCOPED_TRACE(labelModeName(mode));
        Scene s = plain;
        s.labels = writeLayer(labelsOnGrid([](auto, auto, auto) { return 0; }), "empty", mode);
        const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
        if (mode == LabelMode::Alone) {
            for (float p : img.pixels)
                EXPECT_EQ(p, 0.0f);
        } else {
            EXPECT_LE(maxAbsDiff(img, withoutLabels), 1e-5);
        }
    }
}

TEST(Labels, OneVoxelLabelAndLabels0And255) {
    const Volume v = ramp();
    const TransferFunction tf = rampTf();
    // One voxel of label 255 beside a slab of label 1; 255 is the uint8 maximum (a 257-entry device table).
    const Volume labels = labelsOnGrid([](std::size_t i, std::size_t j, std::size_t k) {
        if (i == 16 && j == 16 && k == 16) return 255;
        return i >= 24 && i <= 26 ? 1 : 0;
    });
    const std::string table = R"({"labels": [{"label": 255, "color": [1, 1, 0], "opacity": 0.9},
                                             {"label": 1, "color": [0, 0.5, 1], "opacity": 0.2}]})";
    for (LabelMode mode : {LabelMode::Replace, LabelMode::Alone}) {
        SCOPED_TRACE(labelModeName(mode));
        Scene s = sphereScene(32);
        s.camera->height = 8.0; // four pixels per voxel around the one voxel (the image centre)
        s.step = 0.05;
        s.labels = writeLayer(labels, "one_voxel", mode, table);
        const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
        EXPECT_TRUE(allFiniteAndBounded(img));
        EXPECT_LE(maxAbsDiff(img, referenceRender(v, tf, s, {.step = 0.05})), 0.03);
        // The one voxel shows as a yellow blob (red = green > blue) in the middle of the image in alone mode.
        if (mode == LabelMode::Alone) {
            double yellow = 0.0;
            for (int y = 0; y < s.height; ++y)
                for (int x = 0; x < s.width; ++x)
                    if (img.at(x, y, 0) > 0.01f && std::abs(img.at(x, y, 0) - img.at(x, y, 1)) < 1e-4f)
                        yellow = std::max(yellow, double(img.at(x, y, 3)));
            EXPECT_GT(yellow, 0.05);
        }
    }
}

TEST(Labels, AllHiddenCutsTheLabelledPartsAway) {
    const Volume v = ramp();
    const TransferFunction tf = rampTf();
    const Volume labels = voxelisedLabels(kDims, {0, 0, 0}, {1, 1, 1}, kIdentityDirection);
    const std::string hidden =
        R"({"labels": [{"label": 1, "visible": false}, {"label": 2, "visible": false}]})";
    for (LabelMode mode : {LabelMode::Replace, LabelMode::Modulate, LabelMode::Alone}) {
        SCOPED_TRACE(labelModeName(mode));
        Scene s = sphereScene(24);
        s.step = 0.25;
        s.labels = writeLayer(labels, "hidden", mode, hidden);
        const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
        EXPECT_TRUE(allFiniteAndBounded(img));
        EXPECT_LE(maxAbsDiff(img, referenceRender(v, tf, s, {.step = 0.25})), 0.02);
        if (mode == LabelMode::Alone)
            for (float p : img.pixels)
                EXPECT_EQ(p, 0.0f);
    }
    // The sphere centres are cut away: a ray along z through A's centre sees only the ramp outside it.
    const LabelField f = makeLabelField(labels, "hidden", LabelTable::fromJson(hidden, "hidden"),
                                        LabelLayer{{}, {}, LabelMode::Replace, false}, v);
    const auto inside = classifyLabels(f, {kA.c[0], kA.c[1], kA.c[2]}, {0.2, 0.4, 0.9, 0.05});
    EXPECT_EQ(inside[3], 0.0);
    const auto outside = classifyLabels(f, {2.0, 2.0, 2.0}, {0.2, 0.4, 0.9, 0.05});
    EXPECT_EQ(outside[3], 0.05);
}

TEST(Labels, SmoothBoundaryWeightsArePartitionsOfUnityBetweenTwoLabels) {
    // Labels 1 | 2 split at x = 10.5 on the same grid, same extinction: no seam at the boundary, and the colour
    // switches where the indicators cross.
    const Volume v = ramp();
    const Volume labels = labelsOnGrid([](std::size_t i, auto, auto) { return i <= 10 ? 1 : 2; });
    const LabelTable t = LabelTable::fromJson(R"({"labels": [{"label": 1, "color": [1, 0, 0], "opacity": 0.5},
                                                             {"label": 2, "color": [0, 1, 0], "opacity": 0.5}]})",
                                              "split");
    const LabelField f = makeLabelField(labels, "split", t, LabelLayer{{}, {}, LabelMode::Alone, false}, v);
    const double tau = -std::log1p(-0.5);
    for (double x = 9.0; x <= 12.0; x += 0.125) {
        const auto e = classifyLabels(f, {x, 5.3, 7.1}, {0, 0, 0, 0});
        EXPECT_NEAR(e[3], tau, 1e-6) << x; // the table holds float
        EXPECT_EQ(e[0], x < 10.5 ? 1.0 : x > 10.5 ? 0.0 : 1.0) << x;
    }
    // Against unlabelled space the extinction ramps from 0 (indicator 1/4) to full (3/4), half at the midpoint.
    const Volume half = labelsOnGrid([](std::size_t i, auto, auto) { return i <= 10 ? 1 : 0; });
    const LabelField g = makeLabelField(half, "half", t, LabelLayer{{}, {}, LabelMode::Alone, false}, v);
    EXPECT_NEAR(classifyLabels(g, {10.5, 3, 3}, {0, 0, 0, 0})[3], 0.5 * tau, 1e-6);
    EXPECT_NEAR(classifyLabels(g, {10.75, 3, 3}, {0, 0, 0, 0})[3], 0.0, 1e-6);
    EXPECT_NEAR(classifyLabels(g, {10.25, 3, 3}, {0, 0, 0, 0})[3], tau, 1e-6);
}

TEST(Labels, LabelVolumesThatAreNotLabelsAreRefusedNamingTheFile) {
    const Volume v = ramp();
    const LabelTable t;
    Volume frac = makeFloatVolume({4, 4, 4}, [](double x, double, double) { return x * 0.5; });
    try {
        makeLabelField(frac, "frac.nii", t, LabelLayer{}, v);
        FAIL() << "fractional labels accepted";
    } catch (const DataError& e) {
        EXPECT_EQ(std::string(e.what()).rfind("frac.nii: ", 0), 0u) << e.what();
    }
    Volume neg({4, 4, 4}, ScalarType::Int16);
    neg.values<std::int16_t>()[5] = -3;
    EXPECT_THROW(makeLabelField(neg, "neg.nrrd", t, LabelLayer{}, v), DataError);
    // Whole numbers stored as float (atlases often are) are labels.
    Volume whole = makeFloatVolume({4, 4, 4}, [](double x, double, double) { return x; });
    EXPECT_EQ(makeLabelField(whole, "whole", t, LabelLayer{}, v).table.size(), 5u);
}

TEST(Labels, RefusedWhereTheyDoNotApplyInOneLine) {
    const Volume v = ramp();
    const TransferFunction tf = rampTf();
    Scene s = sphereScene(8);
    s.labels = writeLayer(labelsOnGrid([](auto, auto, auto) { return 1; }), "refused", LabelMode::Alone);
    auto refused = [&](const Scene& bad) {
        try {
            GridRenderer r(computeContext(), v, tf, bad);
            return std::string();
        } catch (const UsageError& e) {
            return std::string(e.what());
        }
    };
    Scene mip = s;
    mip.mode = RenderMode::Mip;
    EXPECT_NE(refused(mip).find("labels (refused.nrrd) need mode dvr"), std::string::npos);
    Scene pre = s;
    pre.preintegration = Preintegration::Table2d;
    EXPECT_NE(refused(pre).find("pre-integration"), std::string::npos);
    Scene iso = s;
    iso.effects.isosurfaces = {IsoLayer{0.5, {1, 1, 1, 1}}};
    EXPECT_NE(refused(iso).find("iso-surfaces"), std::string::npos);
    // Labels colour one intensity volume: a multi-channel scene with labels is refused when validated.
    Scene channels = s;
    channels.channels.resize(2);
    try {
        channels.validate();
        FAIL() << "labels with channels accepted";
    } catch (const UsageError& e) {
        EXPECT_NE(std::string(e.what()).find("labels are drawn over a single-channel volume"),
                  std::string::npos);
    }
    // Renderers without a label kernel (.vcz bricks, meshes, previews) refuse in one line.
    try {
        checkLabels(s, tf, false);
        FAIL();
    } catch (const UsageError& e) {
        const std::string m = e.what();
        EXPECT_EQ(m.find('\n'), std::string::npos);
        EXPECT_NE(m.find(".vcz"), std::string::npos);
    }
    // Shading, clipping and the crop box combine: the plan keeps them, on the per-ray kernel.
    Scene lit = s;
    volcl::test::shadeWithHeadLight(lit, GradientKind::Cache);
    lit.effects.cropBox = CropBox{{2, 2, 2}, {20, 30, 30}, false};
    GridRenderer r(computeContext(), v, tf, lit);
    EXPECT_TRUE(r.plan().shading);
    EXPECT_TRUE(r.plan().clipping);
    EXPECT_TRUE(r.plan().labels);
    EXPECT_EQ(r.plan().gradientCache, 0);
}

TEST(LabelTables, ReadsJsonSlicerItkSnapAndMricronFiles) {
    const auto dir = tempDir("label_tables");
    writeFile(dir / "slicer.txt", "# Slicer colour table\n0 Background 0 0 0 0\n1 liver 255 128 0 255\n"
                                  "7 vessel 0 0 255 0\n");
    LabelTable slicer = LabelTable::read(dir / "slicer.txt");
    EXPECT_EQ(slicer.state(0), LabelState::Unlabelled);
    EXPECT_EQ(slicer.state(1), LabelState::Visible);
    EXPECT_EQ(slicer.state(7), LabelState::Hidden);
    EXPECT_EQ(slicer.entry(1).name, "liver");
    EXPECT_NEAR(slicer.entry(1).rgb[1], 128.0 / 255.0, 1e-12);
    writeFile(dir / "itk.txt", "################\n    0     0    0    0        0  0  0    \"Clear Label\"\n"
                               "    1   255    0    0        1  1  1    \"Label 1\"\n"
                               "    2     0  255    0      0.5  0  1    \"hidden one\"\n");
    LabelTable itk = LabelTable::read(dir / "itk.txt");
    EXPECT_EQ(itk.state(1), LabelState::Visible);
    EXPECT_EQ(itk.state(2), LabelState::Hidden);
    EXPECT_EQ(itk.entry(1).name, "Label 1");
    // FSL/mricron id-name with the binary palette of the same stem beside it.
    writeFile(dir / "atlas.txt", "0\tUnclassified\n1\tPrecentral_L\t2001\n3\tThird region\n");
    std::string lut(768, '\0');
    lut[1] = char(200);       // red of label 1
    lut[256 + 3] = char(100); // green of label 3
    writeFile(dir / "atlas.lut", lut);
    LabelTable fsl = LabelTable::read(dir / "atlas.txt");
    EXPECT_EQ(fsl.state(0), LabelState::Unlabelled);
    EXPECT_NEAR(fsl.entry(1).rgb[0], 200.0 / 255.0, 1e-12);
    EXPECT_NEAR(fsl.entry(3).rgb[1], 100.0 / 255.0, 1e-12);
    EXPECT_EQ(fsl.entry(1).name, "Precentral_L");
    // Unlisted labels take the default palette: deterministic, distinct neighbours.
    EXPECT_EQ(fsl.entry(40).rgb, defaultLabelEntry(40).rgb);
    EXPECT_NE(defaultLabelEntry(1).rgb, defaultLabelEntry(2).rgb);
    const LabelTable json =
        LabelTable::fromJson(R"({"labels": [{"label": 0, "visible": true, "opacity": 0.5}]})", "j");
    EXPECT_EQ(json.state(0), LabelState::Visible);
}

TEST(LabelTables, BadTablesNameTheFileInOneLine) {
    const auto dir = tempDir("label_tables_bad");
    const std::vector<std::pair<std::string, std::string>> bad = {
        {"garbage.txt", "this is not a table\n"},
        {"colour.txt", "1 liver 255 128 0 999\n"},
        {"negative.txt", "-4 below\n"},
        {"itk.txt", "1 255 0 0 1 1 \"short\"\n"},
        {"empty.txt", "# nothing\n\n"},
        {"short.lut", "abc"},
        {"bad.json", R"({"labels": [{"label": 1, "color": [2, 0, 0]}]})"},
        {"keys.json", R"({"labels": [{"label": 1, "colour": [1, 0, 0]}]})"},
        {"notjson.json", "{"},
    };
    for (const auto& [name, text] : bad) {
        SCOPED_TRACE(name);
        writeFile(dir / name, text);
        try {
            LabelTable::read(dir / name);
            FAIL() << "accepted";
        } catch (const DataError& e) {
            const std::string m = e.what();
            EXPECT_EQ(m.rfind((dir / name).string(), 0), 0u) << m;
            EXPECT_EQ(m.find('\n'), std::string::npos) << m;
        }
    }
}

TEST(LabelTables, MricronAtlasTablesRead) {
    const std::filesystem::path templates = "/usr/share/mricron/templates";
    if (!std::filesystem::exists(templates / "aal.nii.txt"))
        GTEST_SKIP() << "mricron-data is not installed (scripts/apt-packages.txt lists it)";
    const LabelTable aal = LabelTable::read(templates / "aal.nii.txt");
    EXPECT_EQ(aal.listed().size(), 116u);
    EXPECT_EQ(aal.entry(1).name, "Precentral_L");
    const LabelTable jhu = LabelTable::read(templates / "JHU-WhiteMatter-labels-1mm.nii.txt");
    EXPECT_EQ(jhu.state(0), LabelState::Unlabelled);
    EXPECT_EQ(jhu.listed().size(), 49u);
}

} // namespace
