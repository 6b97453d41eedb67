// The dead-zone quantiser and its subband steps.
#include "wavelet/quantise/Quantiser.hpp"

#include "core/Error.hpp"
#include "wavelet/transform/LiftingTransform.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <span>

namespace volcl::codec {

namespace {

// L2 norm of the 1D synthesis basis function of a level-l low or high coefficient.
double synthesisGain(Wavelet w, int level, bool high) {
    const std::size_t n = 1024;
    std::vector<double> line(n, 0.0);
    const std::size_t lowLen = n >> level, highLen = (n >> (level - 1)) - lowLen;
    line[high ? lowLen + highLen / 2 : lowLen / 2] = 1.0;
    reference::inverse3d(std::span<double>(line), {n, 1, 1}, level, w);
    double s = 0;
    for (double v : line)
        s += v * v;
    return std::sqrt(s);
}

} // namespace

// Per-subband steps: a coefficient error e costs about e * gain in the voxel domain, so step = delta / gain.
std::vector<double> subbandSteps(Wavelet w, int levels, double delta) {
    std::vector<double> steps;
    if (levels == 0) return {delta};
    const double lowGain = synthesisGain(w, levels, false);
    steps.push_back(delta / (lowGain * lowGain * lowGain));
    for (int l = 1; l <= levels; ++l) {
        const double gl = synthesisGain(w, l, false), gh = synthesisGain(w, l, true);
        for (int o = 1; o < 8; ++o) {
            const double g = ((o & 1) ? gh : gl) * ((o & 2) ? gh : gl) * ((o & 4) ? gh : gl);
            steps.push_back(delta / g);
        }
    }
    return steps;
}

void quantiseRow(const float* in, std::int32_t* out, std::size_t len, double step, double zeroBelow) {
    const float inv = static_cast<float>(1.0 / step), cap = static_cast<float>(kMaxQuantIndex);
    if (zeroBelow == 1) { // the plain floor (kept apart: it vectorises)
        for (std::size_t i = 0; i < len; ++i) {
            const auto m = static_cast<std::int32_t>(std::min(std::abs(in[i]) * inv, cap));
            out[i] = in[i] < 0 ? -m : m;
        }
        return;
    }
    const float edge = static_cast<float>(zeroBelow);
    for (std::size_t i = 0; i < len; ++i) {
        const float a = std::min(std::abs(in[i]) * inv, cap);
        const auto m = a < edge ? 0 : std::max<std::int32_t>(1, static_cast<std::int32_t>(a));
        out[i] = in[i] < 0 ? -m : m;
    }
}

void quantiseInto(const VczHeader& h, Dims d, const float* c, std::size_t pitch, std::int32_t* q,
                  double zeroBelow) {
    forEachSubbandRow(h, d, [&](std::size_t z, std::size_t y, std::size_t x0, std::size_t len, double step) {
        quantiseRow(c + (z * d.y + y) * pitch + x0, q + (z * d.y + y) * d.x + x0, len, step, zeroBelow);
    });
}

void requantiseInto(const VczHeader& h, Dims d, const float* c, float* dst, std::size_t pitch,
                    double zeroBelow) {
    std::array<std::int32_t, 1024> q; // a brick row is at most 1024 (Encoder::plan)
    forEachSubbandRow(h, d, [&](std::size_t z, std::size_t y, std::size_t x0, std::size_t len, double step) {
        quantiseRow(c + (z * d.y + y) * d.x + x0, q.data(), len, step, zeroBelow);
        dequantiseRow(q.data(), dst + (z * d.y + y) * pitch + x0, len, step, h.reconstructionBias);
    });
}

std::vector<double> mergeMaxima(const std::vector<std::int32_t>& brickMax, std::size_t nsub) {
    if (!brickMax.empty() && std::ranges::max(brickMax) >= 0x7f800000)
        throw DataError("voxel values too large for the float transform: use --lossless");
    std::vector<double> maxAbs(nsub, 0.0);
    for (std::size_t i = 0; i < brickMax.size(); ++i)
        maxAbs[i % nsub] = std::max(maxAbs[i % nsub], double(std::bit_cast<float>(brickMax[i])));
    return maxAbs;
}

void subbandMaxAbs(const VczHeader& h, Dims d, const float* c, std::size_t pitch, std::int32_t* out) {
    for (const auto& sec : sectionLayout(d, h.levels))
        for (const SubbandBox& sb : sec) {
            const std::size_t si = subbandIndex(sb.level, sb.orient);
            std::int32_t m = 0;
            for (std::size_t z = sb.z0; z < sb.z1; ++z)
                for (std::size_t y = sb.y0; y < sb.y1; ++y) {
                    const float* row = c + (z * d.y + y) * pitch;
                    std::int32_t rm = 0;
                    for (std::size_t x = sb.x0; x < sb.x1; ++x) {
                        const std::int32_t a = std::bit_cast<std::int32_t>(row[x]) & 0x7fffffff;
                        rm = a > rm ? a : rm;
                    }
                    m = std::max(m, rm);
                }
            out[si] = std::max(out[si], m);
        }
}

} // namespace volcl::codec
