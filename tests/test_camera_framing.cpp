// Camera framing: named views, orbits, ParaView-style reset camera, fitted orthographic height.
#include "core/Error.hpp"
#include "render/CameraFraming.hpp"
#include "render/VecMath.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using namespace volcl;

const WorldBox kBox{{10, -5, 0}, {40, 40, 20}}; // 40 x 40 x 20, centre (30, 15, 10)

void expectNear(const Vec3& a, const Vec3& b, double tol = 1e-12) {
    for (int i = 0; i < 3; ++i)
        EXPECT_NEAR(a[std::size_t(i)], b[std::size_t(i)], tol) << i;
}

TEST(CameraFraming, ResetCameraFitsTheBoundingSphere) {
    const double r = 0.5 * std::sqrt(40.0 * 40 + 40 * 40 + 20 * 20); // 30
    EXPECT_DOUBLE_EQ(boxRadius(kBox), r);
    const Camera o = frameBox(kBox, namedViewDirection(NamedView::Front), Projection::Orthographic, 30, 1.0);
    expectNear(o.target, {30, 15, 10});
    EXPECT_DOUBLE_EQ(o.height, 2 * r);
    EXPECT_GT(o.eye[1], kBox.hi()[1]); // front: the eye on +y, outside the box
    expectNear(o.up, {0, 0, 1});
    // Taller than wide: the height grows so the sphere still fits across.
    EXPECT_DOUBLE_EQ(frameBox(kBox, {}, Projection::Orthographic, 30, 0.5).height, 4 * r);
    const Camera p = frameBox(kBox, namedViewDirection(NamedView::Left), Projection::Perspective, 30, 1.0);
    EXPECT_NEAR(norm(sub(p.eye, p.target)), r / std::sin(15.0 * 3.14159265358979323846 / 180), 1e-9);
    EXPECT_LT(p.eye[0], kBox.origin[0]);
    EXPECT_THROW(frameBox(kBox, {}, Projection::Orthographic, 30, 0.0), UsageError);
}

TEST(CameraFraming, NamedViewsAndOrbits) {
    expectNear(namedViewDirection(NamedView::Back).towardEye, {0, -1, 0});
    expectNear(namedViewDirection(NamedView::Right).towardEye, {1, 0, 0});
    expectNear(namedViewDirection(NamedView::Top).towardEye, {0, 0, 1});
    expectNear(namedViewDirection(NamedView::Top).up, {0, 1, 0});
    expectNear(namedViewDirection(NamedView::Bottom).towardEye, {0, 0, -1});
    // The orbit starts at the front view, turns toward +x, rises toward +z; up stays perpendicular.
    expectNear(orbitDirection(0, 0).towardEye, {0, 1, 0});
    expectNear(orbitDirection(90, 0).towardEye, {1, 0, 0}, 1e-12);
    for (double az : {-120.0, 0.0, 33.0, 250.0})
        for (double el : {-60.0, 0.0, 45.0, 89.0}) {
            const ViewDirection v = orbitDirection(az, el);
            EXPECT_NEAR(norm(v.towardEye), 1.0, 1e-12);
            EXPECT_NEAR(dot(v.towardEye, v.up), 0.0, 1e-12);
            EXPECT_NEAR(v.towardEye[2], std::sin(el * 3.14159265358979323846 / 180), 1e-12);
            EXPECT_GT(v.up[2], 0.0);
        }
    const ViewDirection iso = namedViewDirection(NamedView::Iso);
    EXPECT_GT(iso.towardEye[0], 0.0);
    EXPECT_GT(iso.towardEye[1], 0.0);
    EXPECT_GT(iso.towardEye[2], 0.0);
    EXPECT_EQ(parseNamedView("iso"), NamedView::Iso);
    EXPECT_THROW(parseNamedView("sideways"), UsageError);
    EXPECT_THROW(orbitDirection(NAN, 0), UsageError);
}

TEST(CameraFraming, FittedHeightShowsEveryCorner) {
    // The camera: eye and target given, looking along -x with +z up; the box is 40 (y) by 20 (z).
    Camera c;
    c.eye = {400, 15, 10};
    c.target = {30, 15, 10};
    c.up = {0, 0, 1};
    EXPECT_NEAR(fittedOrthographicHeight(c, kBox, 1.0), 40 * 1.02, 1e-9);
    EXPECT_NEAR(fittedOrthographicHeight(c, kBox, 4.0), 20 * 1.02, 1e-9); // wide image: z decides
    // An off-centre target needs more height to keep the far corners in view.
    c.target = {30, 15, 0};
    c.eye = {400, 15, 0};
    EXPECT_NEAR(fittedOrthographicHeight(c, kBox, 4.0), 40 * 1.02, 1e-9);
}

} // namespace
