// Checks shared by the light-volume tests of grids and compressed bricks (tests/test_shadow_volume*.cpp).
#pragma once

#include "host/tf/TransferFunction.hpp"
#include "render/Scene.hpp"
#include "render/VecMath.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

namespace volcl::test {

/// Renderer `r` built for `s` (a directional light): its first frame builds the light volume, a camera move alone
/// keeps it, the TF `other` rebuilds it. `R`: GridRenderer or BrickRenderer (lightVolumeBuilds()).
template <class R>
void expectCameraMoveKeepsAndTfRebuilds(R& r, const Scene& s, const TransferFunction& other) {
    r.render();
    EXPECT_EQ(r.lightVolumeBuilds(), 1);
    EXPECT_GT(r.lastLightVolumeMilliseconds(), 0.0);
    Camera cam = *s.camera;
    cam.eye = {30, 7.5, 7.5};
    r.setView(cam, s.width, s.height, s.step);
    r.render();
    EXPECT_EQ(r.lightVolumeBuilds(), 1) << "a camera move";
    r.setTransferFunction(other);
    r.render();
    EXPECT_EQ(r.lightVolumeBuilds(), 2) << "a new TF";
}

/// `s` lit by a head light of tolerance 2 degrees, drawn by `make(scene)`'s renderer: its camera turned 1 degree
/// about the target keeps the light volume, turned 5 degrees rebuilds it.
template <class Make> void expectHeadLightTolerance(const Scene& s, Make make) {
    Scene head = s;
    head.lights = {{LightKind::Head, {0, 0, 0}, {1, 1, 1}, 1.0}};
    head.effects.headLightToleranceDeg = 2.0;
    auto r = make(head);
    r->render();
    ASSERT_EQ(r->lightVolumeBuilds(), 1);
    const Camera c0 = *head.camera;
    auto turned = [&](double deg) {
        Camera c = c0;
        const Vec3 off = sub(c0.eye, c0.target);
        const double a = deg * 3.14159265358979 / 180.0;
        c.eye = add(c0.target, {off[0] * std::cos(a) + off[2] * std::sin(a), off[1],
                                -off[0] * std::sin(a) + off[2] * std::cos(a)});
        return c;
    };
    r->setView(turned(1.0), head.width, head.height, head.step);
    r->render();
    EXPECT_EQ(r->lightVolumeBuilds(), 1) << "a head light turned 1 degree (tolerance 2)";
    r->setView(turned(5.0), head.width, head.height, head.step);
    r->render();
    EXPECT_EQ(r->lightVolumeBuilds(), 2) << "a head light turned 5 degrees";
}

} // namespace volcl::test
