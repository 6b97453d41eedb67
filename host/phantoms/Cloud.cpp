// Cloud density from seeded noise: improved Perlin noise, Worley F1 noise, their fBm, and the volume loop.
#include "host/phantoms/Cloud.hpp"

#include "core/Error.hpp"
#include "core/runtime/ParallelFor.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

namespace volcl {
namespace {

std::uint64_t splitmix(std::uint64_t& s) {
    std::uint64_t z = (s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

std::uint32_t hash3(std::uint32_t seed, int x, int y, int z) {
    std::uint64_t s = (std::uint64_t(seed) << 32) ^ (std::uint64_t(std::uint32_t(x)) * 0x8da6b343ULL) ^
                      (std::uint64_t(std::uint32_t(y)) * 0xd8163841ULL) ^
                      (std::uint64_t(std::uint32_t(z)) * 0xcb1ab31fULL);
    return std::uint32_t(splitmix(s) >> 32);
}

double fade(double t) {
    return t * t * t * (t * (t * 6 - 15) + 10);
}
double lerp(double a, double b, double t) {
    return a + t * (b - a);
}

/// Ken Perlin's improved noise (2002) with a permutation shuffled from the seed; about [-1, 1].
class Perlin {
public:
    explicit Perlin(std::uint32_t seed) {
        std::array<int, 256> p;
        std::iota(p.begin(), p.end(), 0);
        std::uint64_t s = seed;
        for (int i = 255; i > 0; --i)
            std::swap(p[std::size_t(i)], p[std::size_t(splitmix(s) % std::uint64_t(i + 1))]);
        for (int i = 0; i < 512; ++i)
            perm_[std::size_t(i)] = p[std::size_t(i & 255)];
    }
    double operator()(double x, double y, double z) const {
        const double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
        const int X = int(long(fx) & 255), Y = int(long(fy) & 255), Z = int(long(fz) & 255);
        x -= fx;
        y -= fy;
        z -= fz;
        const double u = fade(x), v = fade(y), w = fade(z);
        auto P = [&](int i) { return perm_[std::size_t(i)]; };
        const int A = P(X) + Y, AA = P(A) + Z, AB = P(A + 1) + Z, B = P(X + 1) + Y, BA = P(B) + Z,
                  BB = P(B + 1) + Z;
        return lerp(lerp(lerp(grad(P(AA), x, y, z), grad(P(BA), x - 1, y, z), u),
                         lerp(grad(P(AB), x, y - 1, z), grad(P(BB), x - 1, y - 1, z), u), v),
                    lerp(lerp(grad(P(AA + 1), x, y, z - 1), grad(P(BA + 1), x - 1, y, z - 1), u),
                         lerp(grad(P(AB + 1), x, y - 1, z - 1), grad(P(BB + 1), x - 1, y - 1, z - 1), u), v),
                    w);
    }

private:
    static double grad(int h, double x, double y, double z) {
        h &= 15;
        const double u = h < 8 ? x : y, v = h < 4 ? y : (h == 12 || h == 14 ? x : z);
        return ((h & 1) ? -u : u) + ((h & 2) ? -v : v);
    }
    std::array<int, 512> perm_{};
};

/// Worley F1: distance to the nearest of one feature point per unit cell, clamped to [0, 1].
double worley(std::uint32_t seed, double x, double y, double z) {
    const int cx = int(std::floor(x)), cy = int(std::floor(y)), cz = int(std::floor(z));
    double best = 1e30;
    for (int k = -1; k <= 1; ++k)
        for (int j = -1; j <= 1; ++j)
            for (int i = -1; i <= 1; ++i) {
                const std::uint32_t h = hash3(seed, cx + i, cy + j, cz + k);
                const double px = cx + i + double(h & 1023) / 1023.0,
                             py = cy + j + double((h >> 10) & 1023) / 1023.0,
                             pz = cz + k + double((h >> 20) & 1023) / 1023.0;
                const double d2 = (px - x) * (px - x) + (py - y) * (py - y) + (pz - z) * (pz - z);
                best = std::min(best, d2);
            }
    return std::min(std::sqrt(best), 1.0);
}

double smoothstep(double a, double b, double x) {
    const double t = std::clamp((x - a) / (b - a), 0.0, 1.0);
    return t * t * (3 - 2 * t);
}

void check(bool ok, const char* what) {
    if (!ok) throw UsageError(what);
}

void validate(const CloudParams& p) {
    check(p.dims.x > 0 && p.dims.y > 0 && p.dims.z > 0, "cloud: every dimension must be positive");
    check(p.octaves >= 1 && p.octaves <= 12, "cloud: octaves must be in [1, 12]");
    check(std::isfinite(p.frequency) && p.frequency > 0.0 && p.frequency <= 1e4,
          "cloud: frequency must be in (0, 1e4]");
    check(std::isfinite(p.coverage) && p.coverage > 0.0 && p.coverage <= 1.0,
          "cloud: coverage must be in (0, 1]");
    check(std::isfinite(p.erosion) && p.erosion >= 0.0 && p.erosion <= 1.0,
          "cloud: erosion must be in [0, 1]");
}

/// The density from noise evaluators (shared by cloudDensity and the volume loop).
double density(const CloudParams& p, const Perlin& perlin, double x, double y, double z, double h) {
    double f = 0.0, amp = 1.0, norm = 0.0, s = 1.0;
    for (int o = 0; o < p.octaves; ++o) {
        f += amp * perlin(x * s, y * s, z * s);
        norm += amp;
        amp *= 0.5;
        s *= 2.0;
    }
    const double shape = std::clamp(0.5 + 0.5 * f / norm * 1.6, 0.0, 1.0); // fBm to about [0, 1]
    // Worley fBm (inverted: 1 at the feature points) at 2, 4, 8 times the base frequency.
    // Skipped without erosion (its weight is 0; the cellular search dominates the cost of a voxel).
    const double w = p.erosion == 0.0 ? 0.0
                                      : 0.625 * (1.0 - worley(p.seed, 2 * x, 2 * y, 2 * z)) +
                                            0.25 * (1.0 - worley(p.seed + 1, 4 * x, 4 * y, 4 * z)) +
                                            0.125 * (1.0 - worley(p.seed + 2, 8 * x, 8 * y, 8 * z));
    const double base = shape * (1.0 - p.erosion) + p.erosion * shape * w;
    // Flat-ish bottoms and rounded tops: the profile thins the cloud near both ends of the layer.
    const double profile = smoothstep(0.0, 0.15, h) * (1.0 - smoothstep(0.55, 1.0, h));
    const double threshold = 1.0 - p.coverage;
    return std::clamp((base * profile - threshold * (1.0 - p.erosion * 0.5)) / std::max(p.coverage, 1e-9),
                      0.0, 1.0);
}

} // namespace

CloudParams roettgerCloudPreset() {
    CloudParams p;
    p.dims = {513, 513, 65};
    p.frequency = 6.0;
    return p;
}

double cloudDensity(const CloudParams& p, double x, double y, double z, double h) {
    validate(p);
    return density(p, Perlin(p.seed), x, y, z, h);
}

void generateCloudRegion(const CloudParams& p, Dims lo, Volume& out, unsigned threads) {
    validate(p);
    const Dims d = out.dims();
    if (out.type() != ScalarType::UInt8 || lo.x + d.x > p.dims.x || lo.y + d.y > p.dims.y ||
        lo.z + d.z > p.dims.z)
        throw Error("internal: cloud region outside the cloud or not uint8");
    const Perlin perlin(p.seed);
    auto values = out.values<std::uint8_t>();
    const double extent = double(std::max({p.dims.x, p.dims.y, p.dims.z}) - 1);
    const double scale = extent > 0.0 ? p.frequency / extent : 0.0;
    const double zTop = double(p.dims.z - 1);
    parallelFor(d.z * d.y, threads, [&](std::size_t row) {
        const std::size_t k = lo.z + row / d.y, j = lo.y + row % d.y;
        const double h = zTop > 0.0 ? double(k) / zTop : 0.5;
        for (std::size_t i = 0; i < d.x; ++i) {
            const double v = density(p, perlin, double(lo.x + i) * scale + 0.5, double(j) * scale + 0.5,
                                     double(k) * scale + 0.5, h);
            values[out.index(i, j - lo.y, k - lo.z)] = std::uint8_t(std::lround(v * 255.0));
        }
    });
}

Volume generateCloud(const CloudParams& p, unsigned threads) {
    validate(p);
    Volume v(p.dims, ScalarType::UInt8);
    generateCloudRegion(p, {0, 0, 0}, v, threads);
    return v;
}

} // namespace volcl
