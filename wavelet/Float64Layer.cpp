// The float64 layer: exact XOR byte planes or float64 corrections over a float32 layer, and the lossy bound
// check in double that chooses the corrections.
#include "wavelet/Float64Layer.hpp"

#include "core/Error.hpp"

#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>

namespace volcl::codec {

namespace {

std::uint64_t bitsOf(double v) noexcept {
    std::uint64_t u;
    std::memcpy(&u, &v, 8);
    return u;
}

double fromBits(std::uint64_t u) noexcept {
    double v;
    std::memcpy(&v, &u, 8);
    return v;
}

std::vector<std::uint8_t> zstdWithKind(Float64LayerKind kind, std::span<const std::uint8_t> raw) {
    std::vector<std::uint8_t> out(1 + ZSTD_compressBound(raw.size()));
    out[0] = std::uint8_t(kind);
    const std::size_t n = ZSTD_compress(out.data() + 1, out.size() - 1, raw.data(), raw.size(), 3);
    if (ZSTD_isError(n)) throw Error(std::string("zstd compression failed: ") + ZSTD_getErrorName(n));
    out.resize(1 + n);
    return out;
}

// Voxel (x, y, z) of the frame lies in [a, e): its index in the box.
bool inBox(std::size_t i, Dims frame, Dims a, Dims e, Dims outDims, std::size_t& at) {
    const std::size_t x = i % frame.x, y = i / frame.x % frame.y, z = i / (frame.x * frame.y);
    if (x < a.x || x >= e.x || y < a.y || y >= e.y || z < a.z || z >= e.z) return false;
    at = ((z - a.z) * outDims.y + (y - a.y)) * outDims.x + (x - a.x);
    return true;
}

} // namespace

std::vector<std::uint8_t> encodeExactLayer(std::span<const double> voxels, std::span<const float> layer) {
    if (voxels.size() != layer.size()) throw Error("internal: float64 layer of a different size");
    const std::size_t n = voxels.size();
    std::vector<std::uint8_t> planes(8 * n);
    for (std::size_t i = 0; i < n; ++i) {
        const std::uint64_t r = bitsOf(voxels[i]) ^ bitsOf(double(layer[i]));
        for (std::size_t k = 0; k < 8; ++k)
            planes[k * n + i] = std::uint8_t(r >> (8 * k));
    }
    return zstdWithKind(Float64LayerKind::Exact, planes);
}

std::vector<Correction> float64Outliers(std::span<const double> voxels, std::span<const float> layer,
                                        const Float64Bound& bound) {
    if (voxels.size() != layer.size()) throw Error("internal: float64 layer of a different size");
    if (voxels.size() > kMaxFloat64LayerVoxels)
        throw UsageError("a float64 frame of more than 2^32 voxels cannot be coded");
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    std::size_t finite = 0;
    for (double v : voxels)
        if (std::isfinite(v)) {
            lo = std::min(lo, v);
            hi = std::max(hi, v);
            ++finite;
        }
    // R x (max - min) without overflowing when the range exceeds double's.
    const double relAllowed = finite ? bound.target * hi - bound.target * lo : 0.0;
    // PSNR: errors relative to the range (halves: no overflow), so data near DBL_MAX has a PSNR too.
    const double halfRange = finite ? 0.5 * hi - 0.5 * lo : 0.0;
    std::vector<char> exact(voxels.size(), 0);
    std::vector<double> sq; // squared errors of the finite voxels (PSNR)
    if (bound.rate == RateMode::Psnr) sq.assign(voxels.size(), 0.0);
    for (std::size_t i = 0; i < voxels.size(); ++i) {
        const double x = voxels[i], d = layer[i];
        if (!std::isfinite(x) || (x == 0 && d == 0 && std::signbit(x) != std::signbit(d))) {
            exact[i] = 1;
            continue;
        }
        const double err = std::abs(x - d);
        switch (bound.rate) {
        case RateMode::MaxError:
            exact[i] = !(err <= bound.target);
            break;
        case RateMode::RelError:
            exact[i] = !(err <= relAllowed);
            break;
        case RateMode::PwRelError:
            exact[i] = !(err <= bound.target * std::abs(x));
            break;
        case RateMode::Psnr: {
            // A finite voxel whose layer value is not finite (or whose error overflows) is always stored;
            // so is any error of a constant volume (its PSNR has no range to refer to).
            const double rel = halfRange > 0 ? 0.5 * err / halfRange : (err > 0 ? INFINITY : 0.0);
            if (!std::isfinite(rel))
                exact[i] = 1;
            else
                sq[i] = rel * rel;
            break;
        }
        default:
            throw Error("internal: float64 layer of a rate mode without a bound");
        }
    }
    if (bound.rate == RateMode::Psnr && finite > 0) {
        // MSE / range^2 <= 10^(-P/10), summed over the finite voxels; the largest errors go first.
        const double allowedSum = std::pow(10.0, -bound.target / 10.0) * double(finite);
        double sum = 0;
        for (std::size_t i = 0; i < sq.size(); ++i)
            if (!exact[i]) sum += sq[i];
        if (!(sum <= allowedSum)) {
            std::vector<std::size_t> order(voxels.size());
            std::iota(order.begin(), order.end(), std::size_t(0));
            std::sort(order.begin(), order.end(),
                      [&](std::size_t p, std::size_t q) { return sq[p] > sq[q]; });
            for (std::size_t i : order) {
                if (sum <= allowedSum || sq[i] == 0) break;
                if (exact[i]) continue;
                exact[i] = 1;
                sum -= sq[i];
            }
            // Summing in another order can leave rounding above the bound: what remains non-zero is stored.
            if (!(sum <= allowedSum))
                for (std::size_t i = 0; i < sq.size(); ++i)
                    if (sq[i] > 0) exact[i] = 1;
        }
    }
    std::vector<Correction> out;
    for (std::size_t i = 0; i < voxels.size(); ++i)
        if (exact[i]) out.push_back({std::uint32_t(i), voxels[i]});
    return out;
}

std::vector<std::uint8_t> encodeCorrectionLayer(const std::vector<Correction>& exact) {
    const std::vector<std::uint8_t> list = encodeCorrections(exact, ScalarType::Float64);
    std::vector<std::uint8_t> out;
    out.reserve(1 + list.size());
    out.push_back(std::uint8_t(Float64LayerKind::Corrections));
    out.insert(out.end(), list.begin(), list.end());
    return out;
}

void applyFloat64Layer(std::span<const std::uint8_t> layer, Dims frameDims, Dims a, Dims e,
                       std::span<double> out, Dims outDims, const std::string& what) {
    if (layer.empty()) throw IoError(what + ": empty float64 layer");
    const std::size_t n = frameDims.count();
    if (n > kMaxFloat64LayerVoxels) throw IoError(what + ": float64 layer of a frame beyond 2^32 voxels");
    const std::span<const std::uint8_t> body = layer.subspan(1);
    if (layer[0] == std::uint8_t(Float64LayerKind::Corrections)) {
        for (const Correction& c :
             decodeCorrections(body, ScalarType::Float64, n, what + ": float64 layer")) {
            std::size_t at = 0;
            if (inBox(c.index, frameDims, a, e, outDims, at)) out[at] = c.value;
        }
        return;
    }
    if (layer[0] != std::uint8_t(Float64LayerKind::Exact))
        throw IoError(what + ": unknown float64 layer kind " + std::to_string(layer[0]));
    const unsigned long long size = ZSTD_getFrameContentSize(body.data(), body.size());
    if (size != 8ull * n) throw IoError(what + ": invalid float64 layer");
    std::vector<std::uint8_t> planes(8 * n);
    const std::size_t got = ZSTD_decompress(planes.data(), planes.size(), body.data(), body.size());
    if (ZSTD_isError(got) || got != planes.size()) throw IoError(what + ": invalid float64 layer");
    for (std::size_t z = a.z; z < e.z; ++z)
        for (std::size_t y = a.y; y < e.y; ++y)
            for (std::size_t x = a.x; x < e.x; ++x) {
                const std::size_t i = (z * frameDims.y + y) * frameDims.x + x;
                std::uint64_t r = 0;
                for (std::size_t k = 0; k < 8; ++k)
                    r |= std::uint64_t(planes[k * n + i]) << (8 * k);
                double& v = out[((z - a.z) * outDims.y + (y - a.y)) * outDims.x + (x - a.x)];
                v = fromBits(bitsOf(v) ^ r);
            }
}

} // namespace volcl::codec
