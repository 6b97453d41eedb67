// Helpers shared by the test suites: temp dirs, shared-data lookup, one compute context per process.
#pragma once

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "host/image/ImageIo.hpp"
#include "host/io/VolumeIo.hpp"
#include "render/Scene.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <string_view>
#include <typeinfo>

namespace volcl::test {

/// Reading `p` must fail with an IoError whose message names the file.
inline void expectIoError(const std::filesystem::path& p, const ReadOptions& o = {}) {
    try {
        (void)readVolumeFile(p, o);
        ADD_FAILURE() << "accepted " << p << " (" << std::filesystem::file_size(p) << " bytes)";
    } catch (const IoError& e) {
        EXPECT_NE(std::string(e.what()).find(p.filename().string()), std::string::npos)
            << "message does not name the file: " << e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << p << ": expected IoError, got " << typeid(e).name() << ": " << e.what();
    }
}

/// Fresh empty directory under the build tree for one test.
inline std::filesystem::path tempDir(const std::string& name) {
    auto d = std::filesystem::path(VOLCL_TEST_TMP_DIR) / name;
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    return d;
}

/// Writes `data` to `p`, replacing it (test inputs made by hand).
inline void writeFile(const std::filesystem::path& p, std::string_view data) {
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out.write(data.data(), static_cast<std::streamsize>(data.size()));
    ASSERT_TRUE(out.good()) << p;
}

/// The whole content of `p` (empty when it cannot be read).
inline std::string readFile(const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Names of the entries of directory `d`: checks that no temporary or partial output stays behind.
inline std::set<std::string> listing(const std::filesystem::path& d) {
    std::set<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(d))
        names.insert(e.path().filename().string());
    return names;
}

/// ../shared/data, or empty when absent (tests then GTEST_SKIP with a message).
inline std::filesystem::path sharedData() {
    std::filesystem::path p(VOLCL_SHARED_DATA_DIR);
    return std::filesystem::is_directory(p) ? p : std::filesystem::path();
}

#define VOLCL_REQUIRE_SHARED_DATA(path)                                                                      \
    do {                                                                                                     \
        if (::volcl::test::sharedData().empty())                                                             \
            GTEST_SKIP() << "../shared/data is absent: skipping tests on real volumes";                      \
        path = ::volcl::test::sharedData();                                                                  \
    } while (0)

/// The BrainWeb T1 MRI of the shared data (180 x 216 x 180 uint8), read from `data` (sharedData()).
inline Volume brainWebMri(const std::filesystem::path& data) {
    ReadOptions ro;
    ro.dims = Dims{180, 216, 180};
    ro.type = ScalarType::UInt8;
    return readVolume(data / "regular/t1_icbm_normal_1mm_pn0_rf0_180x216x180_uint8_1x1.bin-gz", ro);
}

/// Float32 volume with voxel (i, j, k) = f(i, j, k): analytic fields for renderer tests.
inline Volume makeFloatVolume(Dims d, const std::function<double(double, double, double)>& f) {
    Volume v(d, ScalarType::Float32);
    auto vals = v.values<float>();
    for (std::size_t k = 0; k < d.z; ++k)
        for (std::size_t j = 0; j < d.y; ++j)
            for (std::size_t i = 0; i < d.x; ++i)
                vals[v.index(i, j, k)] = float(f(double(i), double(j), double(k)));
    return v;
}

/// `v`'s voxels as float32, same geometry: what a compressed brick pool holds, and the gradient cache's
/// octahedral form for any volume (integer volumes spanning at most 511 take the exact form).
inline Volume asFloat32(const Volume& v) {
    Volume f(v.dims(), ScalarType::Float32);
    const std::vector<float> values = v.toFloat();
    std::copy(values.begin(), values.end(), f.values<float>().begin());
    f.spacing = v.spacing;
    f.origin = v.origin;
    f.direction = v.direction;
    return f;
}

/// One ComputeContext per test process: building contexts and kernels repeatedly only costs time. Never
/// destroyed: released by an exit handler, Oclgrind's context frees into LLVM state its library has already
/// torn down, and the process aborts after passing tests (tests/oclgrind/run_kernels.sh runs tests there).
inline ComputeContext& computeContext() {
    static ComputeContext* cc = new ComputeContext;
    return *cc;
}

/// Largest difference over R, G, B, A of two images of the same size.
inline double maxAbsDiff(const ImageBuffer& a, const ImageBuffer& b) {
    double m = 0.0;
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = 0; c < 4; ++c)
                m = std::max(m, std::abs(double(a.at(x, y, c)) - double(b.at(x, y, c))));
    return m;
}

/// Orthographic camera looking along +z at the centre of a box of `n` voxels, view height `h`, w x ht
/// pixels, no early termination.
inline Scene orthoScene(Dims n, double h, int w = 8, int ht = 8) {
    Scene s;
    Camera c;
    c.target = {double(n.x - 1) / 2, double(n.y - 1) / 2, double(n.z - 1) / 2};
    c.eye = {c.target[0], c.target[1], -50.0};
    c.height = h;
    s.camera = c;
    s.width = w;
    s.height = ht;
    s.earlyTermination = 1.0;
    return s;
}

/// orthoScene() seen from its target + `offset` (an oblique view: all three axes show), sampled at `step`,
/// without empty-space skipping (the references have none).
inline Scene obliqueOrthoScene(Dims n, double h, int w, int ht, const Vec3& offset, double step) {
    Scene s = orthoScene(n, h, w, ht);
    Camera& c = *s.camera;
    c.eye = {c.target[0] + offset[0], c.target[1] + offset[1], c.target[2] + offset[2]};
    s.step = step;
    s.skipping = SkipMode::Off;
    return s;
}

/// Shades `s` with Blinn-Phong (the defaults) under one head light, gradients by `g`, at step 0.25, with no
/// empty-space skipping (the double reference has none).
inline void shadeWithHeadLight(Scene& s, GradientKind g) {
    s.step = 0.25;
    s.lights = {Light{LightKind::Head, {0, 0, -1}, {1, 1, 1}, 1.0}};
    s.effects.shading = true;
    s.effects.shadingGiven = true;
    s.effects.gradient = g;
    s.skipping = SkipMode::Off;
}

} // namespace volcl::test
