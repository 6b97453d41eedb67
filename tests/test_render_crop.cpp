// Cropping box, eight clip planes and the emission-only mode: grids and meshes against closed forms (the length
// of a ray inside a box, the integral of c tau over a linear ramp), hard cases and refusals.
#include "TestUtil.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/mesh/MeshGenerator.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"
#include "render/grid/GridRenderer.hpp"
#include "render/mesh/MeshReference.hpp"
#include "render/mesh/MeshRenderer.hpp"
#include "render/mesh/PtRenderer.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace {

using namespace volcl;
using volcl::test::computeContext;
using volcl::test::makeFloatVolume;
using volcl::test::orthoScene;

constexpr double kTau = 0.08;
const std::array<double, 3> kColour{1.0, 0.5, 0.25};

TransferFunction constantTf() {
    TransferFunction tf;
    tf.domain = {0.0, 2.0};
    tf.color = {{0.0, kColour}};
    tf.extinction = {{0.0, kTau}};
    return tf;
}

/// The ray's interval inside every half-space dot(n, x) + w >= 0 (the box's faces among them), in double: the
/// oracle's own slab intersection. Empty: t1 <= t0.
std::array<double, 2> insideHalfSpaces(const CameraRay& ray, const std::vector<ClipPlane>& planes) {
    double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
    for (const ClipPlane& p : planes) {
        const double a = dot(p.normal, ray.origin) + p.offset, b = dot(p.normal, ray.direction);
        if (b == 0.0) {
            if (a < 0.0) return {0.0, 0.0};
            continue;
        }
        const double t = -a / b;
        if (b > 0.0)
            t0 = std::max(t0, t);
        else
            t1 = std::min(t1, t);
    }
    return {t0, t1};
}

/// Axis-aligned box lo..hi as six half-spaces (written out here, not through cropBoxPlanes()).
std::vector<ClipPlane> boxHalfSpaces(const Vec3& lo, const Vec3& hi) {
    return {{{1, 0, 0}, -lo[0]}, {{-1, 0, 0}, hi[0]}, {{0, 1, 0}, -lo[1]},
            {{0, -1, 0}, hi[1]}, {{0, 0, 1}, -lo[2]}, {{0, 0, -1}, hi[2]}};
}

/// Per pixel: the length L of its ray inside the volume box and `planes`; dvr alpha 1 - exp(-tau L) and emission
/// c tau L of the constant field. Compares every channel of `img` (dvr or emission) within `tol`.
void expectLengthOracle(const ImageBuffer& img, const Scene& s, const Vec3& volumeHi,
                        const std::vector<ClipPlane>& planes, double tol) {
    std::vector<ClipPlane> all = boxHalfSpaces({0, 0, 0}, volumeHi);
    all.insert(all.end(), planes.begin(), planes.end());
    double worst = 0.0;
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x) {
            const auto [t0, t1] = insideHalfSpaces(cameraRay(*s.camera, s.width, s.height, x, y), all);
            const double L = std::max(0.0, t1 - t0);
            std::array<double, 4> want{};
            if (s.mode == RenderMode::Emission) {
                for (int c = 0; c < 3; ++c)
                    want[std::size_t(c)] = kColour[std::size_t(c)] * kTau * L;
            } else {
                const double a = -std::expm1(-kTau * L);
                for (int c = 0; c < 3; ++c)
                    want[std::size_t(c)] = kColour[std::size_t(c)] * a;
                want[3] = a;
            }
            for (int c = 0; c < 4; ++c)
                worst = std::max(worst, std::abs(double(img.at(x, y, c)) - want[std::size_t(c)]));
        }
    EXPECT_LE(worst, tol);
}

/// An oblique orthographic camera over a box of `n` voxels.
Scene obliqueScene(Dims n, int w, int h) {
    return volcl::test::obliqueOrthoScene(n, 30.0, w, h, {-30.0, 20.0, -40.0}, 0.05);
}

TEST(CropBox, GridMatchesTheLengthInsideTheBoxInDvrAndEmission) {
    const Dims n{17, 13, 15};
    const Volume v = makeFloatVolume(n, [](double, double, double) { return 1.0; });
    const Vec3 hi{16, 12, 14};
    const TransferFunction tf = constantTf();
    struct Case {
        const char* name;
        CropBox box;
    };
    const std::vector<Case> cases = {
        {"inside", {{3.2, 2.5, 4.0}, {11.7, 9.0, 12.5}}},
        {"touching the volume's faces", {{0, 0, 0}, {16, 12, 14}}},
        {"reaching past the volume", {{-5, 4, -3}, {8, 40, 9}}},
        {"zero thickness", {{3, 2, 6}, {12, 10, 6}}},
        {"outside the volume", {{20, 0, 0}, {30, 12, 14}}},
    };
    for (RenderMode mode : {RenderMode::Dvr, RenderMode::Emission})
        for (const Case& c : cases) {
            SCOPED_TRACE(std::string(renderModeName(mode)) + ", " + c.name);
            Scene s = obliqueScene(n, 24, 20);
            s.mode = mode;
            s.effects.cropBox = c.box;
            s.validate();
            const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
            expectLengthOracle(img, s, hi, boxHalfSpaces(c.box.lo, c.box.hi), 2e-4);
            const ImageBuffer ref = referenceRender(v, tf, s, {.step = 0.01});
            expectLengthOracle(ref, s, hi, boxHalfSpaces(c.box.lo, c.box.hi), 2e-5);
        }
}

TEST(CropBox, EightPlanesFormingABoxMatchTheHalfSpaceOracle) {
    const Dims n{17, 13, 15};
    const Volume v = makeFloatVolume(n, [](double, double, double) { return 1.0; });
    const TransferFunction tf = constantTf();
    Scene s = obliqueScene(n, 24, 20);
    // Six faces of a box and two oblique planes cutting its corners: an octagonal prism, the full eight planes.
    std::vector<ClipPlane> planes = boxHalfSpaces({2, 1, 2}, {14, 11, 12});
    const double r = 1.0 / std::sqrt(2.0);
    planes.push_back({{-r, -r, 0}, 20.0 * r}); // x + y <= 20
    planes.push_back({{r, -r, 0}, 7.0 * r});   // y - x <= 7
    s.effects.clipPlanes = planes;
    s.validate();
    const ImageBuffer img = GridRenderer(computeContext(), v, tf, s).render();
    expectLengthOracle(img, s, {16, 12, 14}, planes, 2e-4);
    // The same prism as a crop box and two planes.
    Scene c = s;
    c.effects.clipPlanes = {planes[6], planes[7]};
    c.effects.cropBox = CropBox{{2, 1, 2}, {14, 11, 12}};
    c.validate();
    GridRenderer cropped(computeContext(), v, tf, c);
    EXPECT_EQ(cropped.plan().clipPlanes.size(), 8u) << cropped.plan().explain();
    EXPECT_LE(test::maxAbsDiff(cropped.render(), img), 1e-6);
}

TEST(CropBox, RefusesInvertedBoxesAndMoreThanEightPlanes) {
    EXPECT_THROW(parseCropBoxSpec("4,0,0:3,5,5", "--crop-box"), UsageError);
    EXPECT_THROW(parseCropBoxSpec("0,0,0:3,5", "--crop-box"), UsageError);
    EXPECT_THROW(parseCropBoxSpec("0,0,0;3,5,5", "--crop-box"), UsageError);
    EXPECT_THROW(parseCropBoxSpec("0,0,x:3,5,5", "--crop-box"), UsageError);
    const CropBox vox = parseCropBoxSpec("1,2,3:4,5,6vox", "--crop-box");
    EXPECT_TRUE(vox.voxels);
    EXPECT_EQ(vox.lo, (Vec3{1, 2, 3}));
    EXPECT_EQ(vox.hi, (Vec3{4, 5, 6}));
    const CropBox flat = parseCropBoxSpec("0,0,2.5:3,5,2.5", "--crop-box"); // zero thickness is a box
    EXPECT_FALSE(flat.voxels);

    Scene s;
    s.effects.cropBox = CropBox{{0, 0, 0}, {1, 1, 1}};
    s.effects.clipPlanes = {{{1, 0, 0}, 0.0}, {{0, 1, 0}, 0.0}};
    EXPECT_NO_THROW(s.validate()); // 6 + 2 = 8
    s.effects.clipPlanes.push_back({{0, 0, 1}, 0.0});
    EXPECT_THROW(s.validate(), UsageError);
    s.effects.cropBox.reset();
    s.effects.clipPlanes.assign(8, ClipPlane{});
    EXPECT_NO_THROW(s.validate());
    s.effects.clipPlanes.push_back(ClipPlane{});
    EXPECT_THROW(s.validate(), UsageError);
    s.effects.clipPlanes.clear();
    s.effects.cropBox = CropBox{{0, 2, 0}, {1, 1, 1}}; // inverted in y
    EXPECT_THROW(s.validate(), UsageError);
    // A scene file's box round-trips with its units.
    s.effects.cropBox = CropBox{{0, 1, 2}, {3, 4, 5}, true};
    const Scene back = Scene::fromJson(s.toJson());
    ASSERT_TRUE(back.effects.cropBox);
    EXPECT_TRUE(back.effects.cropBox->voxels);
    EXPECT_EQ(back.effects.cropBox->hi, (Vec3{3, 4, 5}));
    EXPECT_THROW(
        Scene::fromJson(R"({"effects": {"crop_box": {"box": [[0, 0, 0], [1, 1, 1]], "units": "mm"}}})"),
        UsageError);
}

TEST(CropBox, VoxelUnitsOnAnOrientedAnisotropicGrid) {
    // Spacing 0.5 x 1 x 2, a shifted origin and a direction that rotates and mirrors: voxel indices map to the
    // marching frame origin + spacing i whatever the direction (it only turns the named views).
    const Dims n{21, 11, 9};
    Volume v = makeFloatVolume(n, [](double, double, double) { return 1.0; });
    v.spacing = {0.5, 1.0, 2.0};
    v.origin = {3.0, -2.0, 1.0};
    v.direction = {0, -1, 0, 1, 0, 0, 0, 0, -1};
    const RenderInput in = RenderInput::borrow(v);
    const TransferFunction tf = constantTf();
    Scene s;
    Camera c;
    c.target = {8.0, 3.0, 9.0};
    c.eye = {8.0, 3.0, -40.0}; // along +z of the marching frame
    c.height = 14.0;
    s.camera = c;
    s.width = 20;
    s.height = 18;
    s.step = 0.05;
    s.earlyTermination = 1.0;
    s.skipping = SkipMode::Off;
    Scene vox = s;
    vox.effects.cropBox = parseCropBoxSpec("4,2,3:14,8,7vox", "--crop-box");
    const Scene resolved = in.resolved(vox);
    ASSERT_TRUE(resolved.effects.cropBox && !resolved.effects.cropBox->voxels);
    const Vec3 lo{3.0 + 0.5 * 4, -2.0 + 1.0 * 2, 1.0 + 2.0 * 3},
        hi{3.0 + 0.5 * 14, -2.0 + 1.0 * 8, 1.0 + 2.0 * 7};
    for (int a = 0; a < 3; ++a) {
        EXPECT_DOUBLE_EQ(resolved.effects.cropBox->lo[a], lo[a]);
        EXPECT_DOUBLE_EQ(resolved.effects.cropBox->hi[a], hi[a]);
    }
    Scene world = s;
    world.effects.cropBox = CropBox{lo, hi};
    const ImageBuffer a = in.makeRenderer(computeContext(), tf, vox)->render();
    const ImageBuffer b = in.makeRenderer(computeContext(), tf, world)->render();
    EXPECT_EQ(a.pixels, b.pixels);
    // Closed form: inside the crop's x, y range a ray crosses z from 7 to 15, length 8.
    const double alpha = -std::expm1(-kTau * 8.0);
    int inside = 0;
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x) {
            const CameraRay r = cameraRay(c, s.width, s.height, x, y);
            const bool in2d =
                r.origin[0] > lo[0] && r.origin[0] < hi[0] && r.origin[1] > lo[1] && r.origin[1] < hi[1];
            if (!in2d) continue;
            ++inside;
            EXPECT_NEAR(a.at(x, y, 3), alpha, 2e-5) << x << "," << y;
        }
    EXPECT_GT(inside, 20);
    // The double reference takes the input's resolution too.
    const ImageBuffer ref = in.renderReference(tf, vox, {.step = 0.01});
    EXPECT_LT(test::maxAbsDiff(ref, a), 2e-4);
}

TEST(CropBox, MeshCellCasterAndProjectedTetrahedraMatchTheOracleAndRefuseVoxelUnits) {
    const mesh::TetMesh m = mesh::generateHexGridMesh({4, 3, 4}, {0, 0, 0}, {16, 12, 14},
                                                      [](double, double, double) { return 1.0; });
    const TransferFunction tf = constantTf();
    for (RenderMode mode : {RenderMode::Dvr, RenderMode::Emission})
        for (const CropBox& box :
             {CropBox{{3.2, 2.5, 4.0}, {11.7, 9.0, 12.5}}, CropBox{{20, 0, 0}, {30, 12, 14}}}) {
            SCOPED_TRACE(std::string(renderModeName(mode)) + (box.lo[0] > 16 ? ", outside" : ", inside"));
            Scene s = obliqueScene({17, 13, 15}, 24, 20);
            s.mode = mode;
            s.preintegration = Preintegration::Table3d; // dvr: exact per cell segment (point sampling is not)
            s.effects.cropBox = box;
            const ImageBuffer img = MeshRenderer(computeContext(), m, tf, s).render();
            expectLengthOracle(img, s, {16, 12, 14}, boxHalfSpaces(box.lo, box.hi), 2e-4);
            if (mode == RenderMode::Dvr) { // projected tetrahedra cut their segments at the same planes
                s.meshMethod = MeshMethod::ProjectedTetrahedra;
                const ImageBuffer pt = PtRenderer(computeContext(), m, tf, s).render();
                // Its table holds half floats (relative 2^-11): the tolerance of the pt tests.
                expectLengthOracle(pt, s, {16, 12, 14}, boxHalfSpaces(box.lo, box.hi), 1e-3);
            }
            expectLengthOracle(meshReferenceRender(m, tf, s), s, {16, 12, 14}, boxHalfSpaces(box.lo, box.hi),
                               1e-6);
        }
    Scene s = obliqueScene({17, 13, 15}, 8, 8);
    s.effects.cropBox = CropBox{{0, 0, 0}, {2, 2, 2}, true};
    const RenderInput in = RenderInput::borrowMesh(m);
    EXPECT_THROW(in.makeRenderer(computeContext(), tf, s), UsageError);
}

/// Emission along +z through the ramp s = z: c(s) = (s / 20, 1 - s / 20, 0.5), tau(s) = a + b s, integrated in
/// closed form from z0 to z1.
constexpr double kA = 0.01, kB = 0.001;
std::array<double, 3> rampEmission(double z0, double z1) {
    auto red = [](double z) { return kA * z * z / 40.0 + kB * z * z * z / 60.0; };
    auto tauInt = [](double z) { return kA * z + kB * z * z / 2.0; };
    auto green = [&](double z) { return tauInt(z) - red(z); };
    return {red(z1) - red(z0), green(z1) - green(z0), 0.5 * (tauInt(z1) - tauInt(z0))};
}

TransferFunction rampTf() {
    TransferFunction tf;
    tf.domain = {0.0, 20.0};
    tf.color = {{0.0, {0.0, 1.0, 0.5}}, {20.0, {1.0, 0.0, 0.5}}};
    tf.extinction = {{0.0, kA}, {20.0, kA + 20.0 * kB}};
    return tf;
}

/// Every pixel of `img` whose ray runs inside x, y of the box: the ramp's emission from z0 to z1, alpha 0.
void expectRampEmission(const ImageBuffer& img, const Scene& s, double z0, double z1, double tol) {
    const std::array<double, 3> want = rampEmission(z0, z1);
    ASSERT_GT(want[0], 0.01);
    int checked = 0;
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x) {
            const CameraRay r = cameraRay(*s.camera, s.width, s.height, x, y);
            if (!(r.origin[0] > 0.5 && r.origin[0] < 7.5 && r.origin[1] > 0.5 && r.origin[1] < 7.5)) continue;
            ++checked;
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(img.at(x, y, c), want[std::size_t(c)], tol) << x << "," << y << " channel " << c;
            EXPECT_EQ(img.at(x, y, 3), 0.0f);
        }
    EXPECT_GT(checked, 10);
}

Scene rampScene() {
    Scene s = orthoScene({9, 9, 21}, 10.0, 12, 12);
    s.mode = RenderMode::Emission;
    s.step = 0.1;
    s.skipping = SkipMode::Off;
    return s;
}

TEST(Emission, GridMatchesTheClosedFormIntegralOfALinearRamp) {
    const Volume v = makeFloatVolume({9, 9, 21}, [](double, double, double z) { return z; });
    const TransferFunction tf = rampTf();
    Scene s = rampScene();
    GridRenderer r(computeContext(), v, tf, s);
    expectRampEmission(r.render(), s, 0.0, 20.0, 2e-5);
    expectRampEmission(referenceRender(v, tf, s, {.step = 0.01}), s, 0.0, 20.0, 1e-6);
    // Cropped to z in [3.3, 15.7]: the integral over that part only.
    s.effects.cropBox = CropBox{{-1, -1, 3.3}, {9, 9, 15.7}};
    expectRampEmission(GridRenderer(computeContext(), v, tf, s).render(), s, 3.3, 15.7, 2e-5);
    // The planner says what it does, and drops what has no meaning without absorption.
    Scene p = rampScene();
    p.preintegration = Preintegration::Table2d;
    p.effects.fog.enabled = true;
    p.effects.fog.density = 0.1;
    const EffectPlan plan = GridRenderer(computeContext(), v, tf, p).plan();
    const std::string text = plan.explain();
    EXPECT_NE(text.find("emission only"), std::string::npos) << text;
    EXPECT_NE(text.find("pre-integration: mode emission"), std::string::npos) << text;
    EXPECT_NE(text.find("fog: mode emission"), std::string::npos) << text;
    EXPECT_FALSE(plan.fog);
}

TEST(Emission, MeshCellCasterIsExactOnALinearRampAndOtherMethodsRefuse) {
    const mesh::TetMesh m = mesh::generateHexGridMesh({4, 4, 10}, {0, 0, 0}, {8, 8, 20},
                                                      [](double, double, double z) { return z; });
    const TransferFunction tf = rampTf();
    Scene s = rampScene();
    expectRampEmission(MeshRenderer(computeContext(), m, tf, s).render(), s, 0.0, 20.0, 2e-5);
    expectRampEmission(meshReferenceRender(m, tf, s), s, 0.0, 20.0, 1e-6);
    s.effects.cropBox = CropBox{{-1, -1, 3.3}, {9, 9, 15.7}};
    expectRampEmission(MeshRenderer(computeContext(), m, tf, s).render(), s, 3.3, 15.7, 2e-5);
    const RenderInput in = RenderInput::borrowMesh(m);
    for (MeshMethod method : {MeshMethod::KBuffer, MeshMethod::ProjectedTetrahedra}) {
        Scene k = rampScene();
        k.meshMethod = method;
        EXPECT_THROW(in.makeRenderer(computeContext(), tf, k), UsageError) << meshMethodName(method);
    }
}

TEST(Emission, ThinMediaEqualDvr) {
    // Without absorption's effect (tau L << 1) dvr tends to emission: the two models share their scale.
    const Volume v = makeFloatVolume({9, 9, 21}, [](double, double, double z) { return z; });
    TransferFunction tf = rampTf();
    tf.extinction = {{0.0, 1e-5}, {20.0, 3e-5}};
    Scene s = rampScene();
    const ImageBuffer e = GridRenderer(computeContext(), v, tf, s).render();
    s.mode = RenderMode::Dvr;
    const ImageBuffer d = GridRenderer(computeContext(), v, tf, s).render();
    double worst = 0.0, largest = 0.0;
    for (int y = 0; y < s.height; ++y)
        for (int x = 0; x < s.width; ++x)
            for (int c = 0; c < 3; ++c) {
                worst = std::max(worst, double(std::abs(e.at(x, y, c) - d.at(x, y, c))));
                largest = std::max(largest, double(e.at(x, y, c)));
            }
    EXPECT_GT(largest, 1e-4);
    EXPECT_LT(worst, 1e-3 * largest);
}

} // namespace
