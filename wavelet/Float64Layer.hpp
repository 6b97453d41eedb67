// The float64 layer of a float64 volume's .vcz: what turns its coded float32 layer back into float64 voxels,
// bit for bit (lossless) or within the bound checked in double (lossy).
#pragma once

#include "core/Volume.hpp"
#include "wavelet/CodecTypes.hpp"
#include "wavelet/quantise/Corrections.hpp"

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace volcl::codec {

/// Kinds of float64 layer (the first byte of the block; stored in .vcz files: never renumber).
enum class Float64LayerKind : std::uint8_t {
    /// Every voxel's bits XOR the bits of its float32 layer value widened to double, as eight byte planes
    /// (low bytes first) in one zstd frame: bit-exact, NaN payloads, Inf and signed zeros included.
    Exact = 1,
    /// Voxels stored exactly (the correction list's coding over the frame's voxel indices, float64 values);
    /// every other voxel is its float32 layer value.
    Corrections = 2,
};

/// Largest frame a float64 layer indexes (the correction list's 32-bit indices).
inline constexpr std::size_t kMaxFloat64LayerVoxels = std::size_t(1) << 32;

/// The Exact layer of `voxels` against the float32 layer `layer` the decoder will reconstruct.
std::vector<std::uint8_t> encodeExactLayer(std::span<const double> voxels, std::span<const float> layer);

/// A lossy bound in double: what the decoded float32 layer must hold on each voxel.
struct Float64Bound {
    RateMode rate = RateMode::MaxError; ///< MaxError, RelError, PwRelError or Psnr
    double target = 0;                  ///< E, R or the PSNR in dB
};

/// The voxels of `voxels` whose float32 layer value `layer` does not meet `bound` (computed in double: the
/// range of a RelError bound and a PSNR's over the finite voxels), with NaN/Inf voxels and zeros whose
/// layer value has the other sign: stored exactly, these make every voxel meet it. A PSNR bound takes the
/// voxels of largest error until the mean squared error meets it.
std::vector<Correction> float64Outliers(std::span<const double> voxels, std::span<const float> layer,
                                        const Float64Bound& bound);

/// The Corrections layer of the voxels `exact` lists (indices increasing).
std::vector<std::uint8_t> encodeCorrectionLayer(const std::vector<Correction>& exact);

/// Applies a frame's float64 layer (of a frame of `frameDims`) to the box [a, e) of it: `out` (dims
/// `outDims` = e - a, x fastest) holds the float32 layer's values there, widened, and receives the voxels.
/// IoError naming `what` on an inconsistent layer.
void applyFloat64Layer(std::span<const std::uint8_t> layer, Dims frameDims, Dims a, Dims e,
                       std::span<double> out, Dims outDims, const std::string& what);

} // namespace volcl::codec
