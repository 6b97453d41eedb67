// The gradient cache of compressed bricks: the words the device builds against their C++ reference at every
// node (brick faces included), their rebuild when a neighbour changes, and shaded .vcz frames from the packet
// kernel against the grid cache of the decoded volume, the double reference, and a seam check at brick faces.
#include "TestUtil.hpp"

#include "render/Reference.hpp"
#include "render/bricks/BrickField.hpp"
#include "render/bricks/BrickGradientCache.hpp"
#include "render/bricks/BrickLod.hpp"
#include "render/bricks/BrickRenderer.hpp"
#include "render/grid/GradientCache.hpp"
#include "render/grid/GridRenderer.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/LodStatistics.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>

namespace volcl {
namespace {

using test::computeContext;

constexpr Dims kDims{40, 37, 35}; // partial bricks on every axis for bricks of 8 and 16

/// uint8 volume with structure across brick faces: a smooth sphere centred on the brick corner (16, 16, 16)
/// (a corner for bricks of 8 and 16), a ramp in x, and a 1-voxel-thick plate on the brick face x = 24
/// (the first voxel of brick 3 for bricks of 8; inside brick 1 for bricks of 16, where z = 16 is a face: a
/// second plate there).
Volume borderPhantom() {
    Volume v(kDims, ScalarType::UInt8);
    auto out = v.values<std::uint8_t>();
    for (std::size_t k = 0; k < kDims.z; ++k)
        for (std::size_t j = 0; j < kDims.y; ++j)
            for (std::size_t i = 0; i < kDims.x; ++i) {
                const double dx = double(i) - 16, dy = double(j) - 16, dz = double(k) - 16;
                const double r = std::sqrt(dx * dx + dy * dy + dz * dz);
                double s = 30 + 2.0 * double(i) + 140.0 / (1.0 + std::exp((r - 11.0) / 1.5));
                if (i == 24 && j >= 4 && j < 30) s = 220;
                if (k == 16 && i >= 28 && j < 20) s = 200;
                out[v.index(i, j, k)] = std::uint8_t(std::clamp(std::round(s), 0.0, 255.0));
            }
    return v;
}

std::shared_ptr<const VczReader> encode(const Volume& v, std::size_t brick, bool lossy) {
    ComputeContext& cc = computeContext();
    CodecOptions o;
    o.brick = {brick, brick, brick};
    o.levels = 2;
    if (lossy) {
        o.rate = RateMode::MaxError;
        o.target = 2.0;
    }
    std::vector<std::byte> bytes = encodeVolume(cc, v, o);
    bytes = addLodStatistics(cc, std::move(bytes), std::span<const Volume>(&v, 1), "border.vcz");
    return std::make_shared<const VczReader>(std::move(bytes), "border.vcz");
}

TransferFunction borderTf() {
    TransferFunction tf;
    tf.domain = {0, 255};
    tf.color = {{0, {0.9, 0.6, 0.3}}, {120, {0.5, 0.8, 0.9}}, {255, {1.0, 1.0, 0.9}}};
    tf.extinction = {{0, 0.0}, {60, 0.0}, {110, 0.08}, {180, 0.4}, {255, 0.9}};
    return tf;
}

/// Shaded orthographic view along +z (image columns follow x, rows y: brick faces are pixel columns and rows),
/// head light, no skipping or early termination (the references have neither).
Scene borderScene(GradientKind g, int size = 80) {
    Scene s = test::orthoScene(kDims, 42, size, size);
    test::shadeWithHeadLight(s, g);
    s.lod = LodMode::Full;
    return s;
}

/// Per-brick levels: a checkerboard of 0 and 1, every other brick of level 1 at 2 where the file has it.
std::vector<int> mixedLevels(const VczHeader& h) {
    const Dims g = h.brickGrid();
    std::vector<int> levels(h.brickCount());
    for (std::size_t b = 0; b < levels.size(); ++b) {
        const std::size_t x = b % g.x, y = b / g.x % g.y, z = b / (g.x * g.y);
        levels[b] = (x + y + z) % 2 == 0 ? 0 : 1 + int((x + 2 * y + z) % 4 == 1);
    }
    return levels;
}

/// Words decoded to gradients agree: exactly, or (node values of coarse bricks computed in double by
/// brickNodeValues, in float by the kernel) within one code of direction and magnitude; `exact` counts the
/// equal words.
void expectWordsMatch(const std::vector<std::uint32_t>& got, const std::vector<std::uint32_t>& want,
                      float gMax, const std::string& what, std::size_t& exact) {
    ASSERT_EQ(got.size(), want.size()) << what;
    for (std::size_t i = 0; i < got.size(); ++i) {
        if (got[i] == want[i]) {
            ++exact;
            continue;
        }
        const Vec3 a = unpackGradient(got[i], gMax), b = unpackGradient(want[i], gMax);
        const double la = norm(a), lb = norm(b);
        EXPECT_LE(std::abs(la - lb), 0.07 * std::max(la, lb) + 1e-6 * gMax) << what << ", sample " << i;
        if (la > 1e-4 * gMax && lb > 1e-4 * gMax)
            EXPECT_GT(dot(a, b) / (la * lb), 0.99995) << what << ", sample " << i;
    }
}

// Every word of every resident brick (faces included) is the central difference of the global node lattice:
// at level 0 the grid cache's word of the decoded volume, bit for bit; with mixed levels the reference's on
// the node values. After a neighbour changes level only the touched bricks are rebuilt, and their face words
// follow.
TEST(BrickGradientCache, WordsAreTheGlobalLatticeGradientsAtEveryNode) {
    ComputeContext& cc = computeContext();
    const Volume v = borderPhantom();
    const TransferFunction tf = borderTf();
    for (std::size_t brick : {8u, 16u}) {
        const auto reader = encode(v, brick, false);
        const VczHeader& h = reader->header();
        BrickRenderer r(cc, reader, 0, tf, borderScene(GradientKind::Cache));
        ASSERT_EQ(r.plan().gradientCache, 1) << r.plan().explain();
        r.setForcedLevels(std::vector<int>(h.brickCount(), 0));
        r.render();
        const std::vector<int> used = r.lastSelection().level;
        const Volume decoded = reader->decode(cc);
        const ValueRange range = {
            double(*std::min_element(v.values<std::uint8_t>().begin(), v.values<std::uint8_t>().end())),
            double(*std::max_element(v.values<std::uint8_t>().begin(), v.values<std::uint8_t>().end()))};
        const float scale = gradientCacheScale(h.spacing, range);
        const std::vector<std::uint32_t> grid = gradientCacheReference(decoded, scale);
        std::size_t resident = 0;
        for (std::size_t b = 0; b < h.brickCount(); ++b) {
            const std::vector<std::uint32_t> words = r.gradientWords(b);
            if (used[b] < 0) {
                EXPECT_TRUE(words.empty());
                continue;
            }
            ++resident;
            const Dims o = h.brickOrigin(b), d = h.brickDims(b);
            ASSERT_EQ(words.size(), d.count());
            std::size_t i = 0, wrong = 0;
            for (std::size_t z = 0; z < d.z; ++z)
                for (std::size_t y = 0; y < d.y; ++y)
                    for (std::size_t x = 0; x < d.x; ++x)
                        wrong += words[i++] != grid[decoded.index(o.x + x, o.y + y, o.z + z)];
            EXPECT_EQ(wrong, 0u) << "brick " << b << " of " << brick;
        }
        EXPECT_GT(resident, h.brickCount() / 2);
        EXPECT_EQ(r.lastStats().gradientBricks, resident);

        // The same frame again: nothing is rebuilt.
        r.render();
        EXPECT_EQ(r.lastStats().gradientBricks, 0u);
        // Mixed levels: every brick whose level or face neighbours changed is rebuilt.
        const std::vector<int> levels = mixedLevels(h);
        r.setForcedLevels(levels);
        r.render();
        EXPECT_GT(r.lastStats().gradientBricks, 0u);
        const std::vector<int> now = r.lastSelection().level;
        const Volume nodes = brickNodeValues(cc, *reader, 0, now, r.lastSelection().standIn);
        std::size_t exact = 0, total = 0;
        for (std::size_t b = 0; b < h.brickCount(); ++b) {
            if (now[b] < 0) continue;
            const std::vector<std::uint32_t> want = brickGradientReference(nodes, h, b, now[b], scale);
            expectWordsMatch(r.gradientWords(b), want, scale, "brick " + std::to_string(b), exact);
            total += want.size();
        }
        std::cout << "bricks of " << brick << ", mixed levels: " << exact << " of " << total
                  << " words bit for bit\n";
        EXPECT_EQ(exact, total);
        // Back to level 0: the face words of the level-0 bricks next to the former coarse ones follow.
        r.setForcedLevels(std::vector<int>(h.brickCount(), 0));
        r.render();
        for (std::size_t b = 0; b < h.brickCount(); ++b) {
            if (r.lastSelection().level[b] < 0) continue;
            const Dims o = h.brickOrigin(b), d = h.brickDims(b);
            const std::vector<std::uint32_t> words = r.gradientWords(b);
            std::size_t i = 0, wrong = 0;
            for (std::size_t z = 0; z < d.z; ++z)
                for (std::size_t y = 0; y < d.y; ++y)
                    for (std::size_t x = 0; x < d.x; ++x)
                        wrong += words[i++] != grid[decoded.index(o.x + x, o.y + y, o.z + z)];
            EXPECT_EQ(wrong, 0u) << "brick " << b << " of " << brick << " after the levels changed back";
        }
    }
}

/// Mean absolute RGBA error per image column (x) over all rows.
std::vector<double> columnError(const ImageBuffer& a, const ImageBuffer& b) {
    std::vector<double> e(std::size_t(a.width), 0.0);
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x)
            for (int c = 0; c < 4; ++c)
                e[std::size_t(x)] +=
                    std::abs(double(a.at(x, y, c)) - double(b.at(x, y, c))) / (4.0 * a.height);
    return e;
}

// Shaded .vcz frames (lossless and lossy, bricks of 8 and 16, level 0, forced mixed levels and lod auto) on
// the packet kernel. At level 0: the grid cache of the decoded volume (the same words and blend) and the double
// reference. With coarse bricks the cache holds each level's own lattice gradients (smoother than the
// piecewise-constant slopes of the trilinear field the rays see): against the full-resolution reference it
// stays within a stated factor of central differences. Seams: no pixel column showing a brick face errs more
// than the columns beside it.
TEST(BrickGradientCache, ShadedVczMatchesGridCacheAndReferenceWithoutSeams) {
    ComputeContext& cc = computeContext();
    const Volume v = borderPhantom();
    const TransferFunction tf = borderTf();
    for (bool lossy : {false, true})
        for (std::size_t brick : {8u, 16u}) {
            const auto reader = encode(v, brick, lossy);
            const VczHeader& h = reader->header();
            const Volume decoded = reader->decode(cc);
            const std::string name =
                std::string(lossy ? "lossy" : "lossless") + ", bricks of " + std::to_string(brick);
            for (int lod = 0; lod < 3; ++lod) { // level 0, forced mixed levels, render.lod auto
                const std::string how = lod == 0 ? ", level 0" : lod == 1 ? ", mixed levels" : ", lod auto";
                SCOPED_TRACE(name + how);
                Scene s = borderScene(GradientKind::Cache);
                if (lod == 2) {
                    s.lod = LodMode::Auto;
                    s.lodError = 0.05;
                }
                BrickRenderer r(cc, reader, 0, tf, s);
                ASSERT_EQ(r.plan().gradientCache, 1) << r.plan().explain(); // only the packet kernel has it
                if (lod == 1) r.setForcedLevels(mixedLevels(h));
                const ImageBuffer img = r.render();
                for (float px : img.pixels)
                    ASSERT_TRUE(std::isfinite(px));
                const std::vector<int> used = r.lastSelection().level;
                const int coarse = int(std::count_if(used.begin(), used.end(), [](int l) { return l > 0; }));
                if (lod > 0) EXPECT_GT(coarse, 0);
                Scene sc = s;
                sc.effects.gradient = GradientKind::Central;
                BrickRenderer rc(cc, reader, 0, tf, sc);
                rc.setForcedLevels(used);
                EXPECT_EQ(rc.plan().gradientCache, 0);
                const ImageBuffer central = rc.render();
                const ImageBuffer ref = referenceRender(decoded, tf, s, {.step = 0.05});
                const double eRef = imageRmse(img, ref), eCentral = imageRmse(central, ref);
                std::cout << name << how << " (" << coarse << " coarse bricks): RMSE vs the reference: cache "
                          << eRef << ", central differences " << eCentral;
                if (lod == 0) {
                    // As float, the grid takes the octahedral form the pool's float samples take.
                    const ImageBuffer gridCache = GridRenderer(cc, test::asFloat32(decoded), tf, s).render();
                    const double eGrid = imageRmse(img, gridCache);
                    std::cout << "; vs the grid cache of the decoded volume " << eGrid << " (max "
                              << test::maxAbsDiff(img, gridCache) << ")";
                    if (!lossy)
                        EXPECT_LE(test::maxAbsDiff(img, gridCache), 1e-5) << "the same words and blend";
                    else // the cache's scale from the file's value ranges, not from the decoded voxels
                        EXPECT_LT(eGrid, 5e-4);
                    EXPECT_LT(eRef, 1.2 * eCentral + 1e-4);
                } else {
                    EXPECT_LT(eRef, 5.0 * eCentral + 2e-3);
                }
                std::cout << '\n';
                // Seams: each pixel column within a pixel of a brick face errs at most 1.5x the worst column 2-4
                // pixels beside it (+1e-3).
                const std::vector<double> col = columnError(img, ref);
                const double pxPerVoxel = double(s.width) / s.camera->height;
                for (std::size_t bx = brick; bx < kDims.x; bx += brick) {
                    const double xPix = (double(bx) - s.camera->target[0]) * pxPerVoxel + 0.5 * s.width;
                    const int c0 = int(std::floor(xPix));
                    double beside = 0;
                    for (int d : {-4, -3, -2, 3, 4, 5})
                        if (c0 + d >= 0 && c0 + d < s.width)
                            beside = std::max(beside, col[std::size_t(c0 + d)]);
                    for (int c = c0 - 1; c <= c0 + 2; ++c)
                        if (c >= 0 && c < s.width)
                            EXPECT_LE(col[std::size_t(c)], 1.5 * beside + 1e-3)
                                << "column " << c << " at the brick face x = " << bx;
                }
            }
        }
}

// Nearest-node sampling reads one word per lane (or the node's blend in a coarse brick): close to the trilinear
// blend, and it takes the packet kernel too.
TEST(BrickGradientCache, NearestNodeOnMixedLevels) {
    ComputeContext& cc = computeContext();
    const Volume v = borderPhantom();
    const TransferFunction tf = borderTf();
    const auto reader = encode(v, 8, false);
    const Scene s = borderScene(GradientKind::CacheNearest, 48);
    BrickRenderer r(cc, reader, 0, tf, s);
    ASSERT_EQ(r.plan().gradientCache, 2) << r.plan().explain();
    r.setForcedLevels(mixedLevels(reader->header()));
    const ImageBuffer img = r.render();
    const Volume nodes = brickNodeValues(cc, *reader, 0, r.lastSelection().level, r.lastSelection().standIn);
    const ImageBuffer ref = referenceRender(nodes, tf, s, {.step = 0.05});
    Scene sc = s;
    sc.effects.gradient = GradientKind::Central;
    BrickRenderer rc(cc, reader, 0, tf, sc);
    rc.setForcedLevels(r.lastSelection().level);
    const double e = imageRmse(img, ref), eCentral = imageRmse(rc.render(), ref);
    std::cout << "cache-nearest, mixed levels: RMSE " << e << " (central differences " << eCentral << ")\n";
    EXPECT_LT(e, 0.05);
    EXPECT_GE(r.gradientCacheBuildMs(), 0.0);
}

} // namespace
} // namespace volcl
