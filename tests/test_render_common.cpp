// The renderers' shared pieces on their own: include resolution in cl/ subfolders, and a mesh-style kernel
// built from cl/common/ camera rays, shading and TF lookup without grid sampling, against the host.
#include "TestUtil.hpp"

#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/KernelSources.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/FrameParams.hpp"
#include "render/Reference.hpp"
#include "render/Scene.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <optional>
#include <string>

namespace volcl {
namespace {

class ScopedKernelDir {
public:
    explicit ScopedKernelDir(const std::filesystem::path& dir) {
        if (const char* old = std::getenv("VOLCL_KERNEL_DIR")) old_ = old;
        setenv("VOLCL_KERNEL_DIR", dir.c_str(), 1);
    }
    ~ScopedKernelDir() {
        if (old_)
            setenv("VOLCL_KERNEL_DIR", old_->c_str(), 1);
        else
            unsetenv("VOLCL_KERNEL_DIR");
    }

private:
    std::optional<std::string> old_;
};

std::size_t count(const std::string& text, const std::string& what) {
    std::size_t n = 0;
    for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1))
        ++n;
    return n;
}

void write(const std::filesystem::path& p, const std::string& text) {
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p) << text;
}

TEST(KernelIncludes, ResolveBesideTheIncluderThenFromTheRoot) {
    const auto dir = test::tempDir("kernel_includes");
    write(dir / "top.h", "#define TOP 1\n");
    write(dir / "other/c.h", "#define C 3\n");
    write(dir / "sub/b.h", "#define B 2\n");
    // b.h is beside a.h; ../top.h climbs out; other/c.h is not beside a.h, so it is taken from the root.
    write(dir / "sub/a.h", "#include \"b.h\"\n#include \"../top.h\"\n#include \"other/c.h\"\n");
    write(dir / "probe.cl",
          "#include \"sub/a.h\"\n#include \"top.h\"\n#include \"sub/../sub/b.h\"\nint x;\n");
    const std::string src = KernelSourceLibrary(dir).resolve("probe.cl");
    EXPECT_EQ(count(src, "#define TOP 1"), 1u) << src;
    EXPECT_EQ(count(src, "#define B 2"), 1u) << "one file, two spellings, included once\n" << src;
    EXPECT_EQ(count(src, "#define C 3"), 1u) << src;
    EXPECT_NE(src.find("#line 1 \"sub/b.h\""), std::string::npos) << src;
    EXPECT_NE(src.find("#line 1 \"top.h\""), std::string::npos) << src;
    EXPECT_NE(src.find("#line 1 \"other/c.h\""), std::string::npos) << src;
    EXPECT_EQ(src.find("#include \""), std::string::npos) << src;
    // A missing include is a clear error naming the file.
    write(dir / "broken.cl", "#include \"sub/missing.h\"\n");
    try {
        KernelSourceLibrary(dir).resolve("broken.cl");
        FAIL() << "a missing include must not resolve";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("missing.h"), std::string::npos) << e.what();
    }
}

TEST(KernelIncludes, EmbeddedGridKernelIncludesEachCommonHeaderOnce) {
    const std::string src = KernelSourceLibrary().resolve("render/raymarch.cl");
    for (const char* h : {"volcl_shared.h", "common/camera_rays.h", "common/shading.h", "common/tf_lookup.h",
                          "common/grid_sample.h", "render/raymarch_iso.h"})
        EXPECT_EQ(count(src, std::string("#line 1 \"") + h + "\""), 1u) << h;
}

// A kernel the way a mesh renderer would write one: camera rays, lighting and the TF from cl/common/,
// nothing from grid_sample.h. Its rays and lit colours agree with the double-precision host pieces.
TEST(RenderCommon, MeshStyleKernelNeedsNoGridSampling) {
    const auto dir = test::tempDir("render_common_probe");
    const KernelSourceLibrary embedded;
    // The shared headers as the library embeds them (already self-contained), in the same folders.
    for (const char* h : {"volcl_shared.h", "common/camera_rays.h", "common/shading.h", "common/tf_lookup.h"})
        write(dir / h, embedded.resolve(h));
    write(dir / "probe.cl", R"(#include "common/camera_rays.h"
#include "common/shading.h"
#include "common/tf_lookup.h"
typedef struct { VolclCameraParams camera; VolclLightingParams lighting; VolclTfParams tf; } ProbeParams;
__kernel void probe(__global const VolclTfKnot* knots, const ProbeParams P, __global float4* out) {
    const uint x = get_global_id(0), y = get_global_id(1);
    const WorldRay r = camera_ray_world(&P.camera, x, y);
    const float4 e = tf_sample(knots, P.tf.knotCount, (float)x / (float)(P.camera.width - 1));
    const float3 at = r.o + 2.0f * r.d;
    LightSum s = light_begin(&P.lighting, (float3)(0.3f, -0.2f, 0.9f), r.d);
    for (uint i = 0; i < P.lighting.lightCount; ++i) {
        float dist;
        const float3 L = light_dir(&P.lighting, P.camera.perspective, r.o, r.d, (int)i, at, &dist);
        light_add(&s, &P.lighting, (int)i, L, 1.0f, r.d);
    }
    const float3 c = light_finish(&s, &P.lighting, e.xyz);
    const size_t i = ((size_t)y * P.camera.width + x) * 3;
    out[i] = (float4)(r.o, 0.0f);
    out[i + 1] = (float4)(r.d, 0.0f);
    out[i + 2] = (float4)(c, e.w);
}
)");
    const std::string src = KernelSourceLibrary(dir).resolve("probe.cl");
    EXPECT_EQ(src.find("sample_volume"), std::string::npos);
    EXPECT_EQ(src.find("voxel_t"), std::string::npos);

    Scene scene;
    scene.width = 7;
    scene.height = 5;
    Camera cam;
    cam.projection = Projection::Perspective;
    cam.eye = {1.5, -2.0, -6.0};
    cam.target = {0.2, 0.1, 0.3};
    cam.up = {0.1, 1.0, 0.0};
    cam.fovYDeg = 40.0;
    scene.camera = cam;
    scene.lights = {{LightKind::Directional, {0.4, 0.6, -0.7}, {1.0, 0.9, 0.8}, 1.0},
                    {LightKind::Point, {3.0, 2.0, -1.0}, {0.5, 0.5, 1.0}, 2.0},
                    {LightKind::Head, {0, 0, 0}, {1, 1, 1}, 0.5}};
    scene.effects.shading = true;
    scene.effects.scattering = true;
    scene.effects.albedo = 0.6;
    scene.effects.phaseG = 0.3;
    scene.validate();
    TransferFunction tf;
    tf.domain = {0.0, 1.0};
    tf.color = {{0.0, {0.1, 0.2, 0.9}}, {0.5, {0.9, 0.5, 0.2}}, {1.0, {1.0, 1.0, 0.9}}};
    tf.extinction = {{0.0, 0.0}, {0.4, 2.0}, {1.0, 5.0}};
    tf.validate();
    const auto knots = tf.packKnots();
    const double gradientMin = 1e-6;
    struct ProbeParams {
        VolclCameraParams camera;
        VolclLightingParams lighting;
        VolclTfParams tf;
    } params{cameraParams(cam, scene.width, scene.height), lightingParams(scene, gradientMin),
             tfParams(scene, tf, knots.size(), 1)};
    static_assert(sizeof(ProbeParams) == 80 + 176 + 32);

    std::vector<cl_float4> got;
    {
        ScopedKernelDir env(dir);
        ComputeContext cc;
        cl::Kernel k =
            cc.kernel("probe.cl", "probe", KernelDefines().set("SHADING").set("SCATTERING").set("PREINT", 2));
        auto kb = cc.upload(knots, CL_MEM_READ_ONLY);
        auto out = cc.allocate<cl_float4>(std::size_t(scene.width) * scene.height * 3);
        setArgs(k, kb, params, out);
        cc.launch2d(k, scene.width, scene.height, 1, 1);
        got = cc.download(out);
    }
    const ReferenceLighting lighting(scene, cam);
    double worstRay = 0.0, worstColour = 0.0;
    for (int y = 0; y < scene.height; ++y)
        for (int x = 0; x < scene.width; ++x) {
            const std::size_t i = (std::size_t(y) * scene.width + x) * 3;
            const CameraRay ray = cameraRay(cam, scene.width, scene.height, x, y);
            for (int a = 0; a < 3; ++a) {
                worstRay = std::max(worstRay, std::abs(got[i].s[a] - ray.origin[a]));
                worstRay = std::max(worstRay, std::abs(got[i + 1].s[a] - ray.direction[a]));
            }
            const float s = float(x) / float(scene.width - 1);
            const auto e = TransferFunction::sampleFloat(knots, s);
            EXPECT_EQ(got[i + 2].s[3], e[3]) << "tf_sample is bit-identical to the host at " << s;
            const Vec3 c = lighting.light(
                ray, add(ray.origin, scale(ray.direction, 2.0)), {e[0], e[1], e[2]}, gradientMin,
                [] {
                    return Vec3{0.3, -0.2, 0.9};
                },
                [](const Vec3&, double) { return 1.0; });
            for (int a = 0; a < 3; ++a) {
                ASSERT_TRUE(std::isfinite(got[i + 2].s[a]));
                worstColour =
                    std::max(worstColour, std::abs(got[i + 2].s[a] - c[a]) / std::max(1.0, std::abs(c[a])));
            }
        }
    EXPECT_LT(worstRay, 1e-5);
    EXPECT_LT(worstColour, 1e-4);
    EXPECT_GT(worstColour, 0.0)
        << "float against double: some rounding must show (else nothing was compared)";
}

// specular_power (common/shading.h) against double pow: integer exponents by repeated squaring, others by
// exp2(n log2 x). The bound is the one its comment states.
TEST(RenderCommon, SpecularPowerWithinItsStatedBound) {
    const auto dir = test::tempDir("render_common_specular");
    const KernelSourceLibrary embedded;
    for (const char* h : {"volcl_shared.h", "common/camera_rays.h", "common/shading.h"})
        write(dir / h, embedded.resolve(h));
    write(dir / "probe.cl", R"(#include "common/shading.h"
__kernel void probe(__global const float* x, __global const float* n, uint nx, __global float* out) {
    const uint i = get_global_id(0), j = get_global_id(1);
    out[j * nx + i] = specular_power(x[i], n[j]);
}
)");
    std::vector<float> xs,
        ns = {0, 1, 2, 3, 5, 8, 16, 20, 32, 64, 100, 128, 255, 1000, 0.5f, 7.25f, 40.5f, 2000};
    for (int i = 0; i <= 4000; ++i)
        xs.push_back(float(i) / 4000.0f);
    for (float x = 0.9f; x < 1.0f; x = std::nextafter(x, 2.0f) + 1e-6f)
        xs.push_back(x); // near 1, where high exponents keep a visible highlight
    std::vector<float> got;
    {
        ScopedKernelDir env(dir);
        ComputeContext cc;
        cl::Kernel k = cc.kernel("probe.cl", "probe", KernelDefines().set("SHADING"));
        auto xb = cc.upload(xs, CL_MEM_READ_ONLY);
        auto nb = cc.upload(ns, CL_MEM_READ_ONLY);
        auto out = cc.allocate<float>(xs.size() * ns.size());
        setArgs(k, xb, nb, cl_uint(xs.size()), out);
        cc.launch2d(k, xs.size(), ns.size(), 1, 1);
        got = cc.download(out);
    }
    for (std::size_t j = 0; j < ns.size(); ++j) {
        const bool integer = ns[j] == std::floor(ns[j]) && ns[j] <= 1024.0f;
        double worst = 0.0;
        for (std::size_t i = 0; i < xs.size(); ++i) {
            const double want = std::pow(double(xs[i]), double(ns[j]));
            const double g = got[j * xs.size() + i];
            ASSERT_TRUE(std::isfinite(g));
            if (want < 1e-30) {
                EXPECT_LT(g, 1e-29);
                continue;
            }
            worst = std::max(worst, std::abs(g - want) / want);
        }
        // Repeated squaring: at most 2 log2(n) roundings, each doubled by the squarings after it, so below
        // (n + log2 n) 2^-24 relative; exp2(n log2 x): log2's error scaled by n.
        const double bound =
            integer ? (double(ns[j]) + 11.0) * std::ldexp(1.0, -24) : 4e-6 * std::max(1.0, double(ns[j]) / 8);
        EXPECT_LE(worst, bound) << "n = " << ns[j];
    }
}

} // namespace
} // namespace volcl
