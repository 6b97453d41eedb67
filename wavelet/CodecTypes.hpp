// Public types of the codec API and the .vcz header: wavelet filter, entropy coder, rate control, stage
// times.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace volcl {

/// Wavelet filters. Cdf53, Haar and Cdf26 have reversible integer forms (lossless) and linear float forms;
/// Cdf97 is float only. The numeric values are stored in .vcz files: never renumber.
enum class Wavelet : std::uint8_t { Cdf53 = 0, Cdf97 = 1, Haar = 2, Cdf26 = 3 };

std::string_view waveletName(Wavelet w) noexcept; ///< "cdf53", "cdf97", "haar", "cdf26"
/// Parses a wavelet name; throws UsageError listing the valid names.
Wavelet parseWavelet(std::string_view name);
/// True when the wavelet has a reversible integer form.
bool hasIntegerForm(Wavelet w) noexcept;

/// How coefficient sections are entropy coded. Stored in .vcz files: never renumber.
enum class EntropyMode : std::uint8_t {
    Fast = 0,  ///< sign-folded coefficients split into byte planes, then zstd
    Dense = 1, ///< rANS: magnitude classes from per-section tables chosen by neighbour/parent context,
               ///< adaptive signs and row flags, raw mantissa bits
};

std::string_view entropyName(EntropyMode m) noexcept; ///< "fast", "dense"
/// Parses an entropy coder name; throws UsageError listing the valid names.
EntropyMode parseEntropy(std::string_view name);

/// Rate control of an encoding. Stored in .vcz files: never renumber. RelError bounds every finite voxel
/// by R x (max - min) of the frame's finite values, PwRelError by R x |voxel| (zeros exact, signs kept).
enum class RateMode : std::uint8_t {
    Lossless = 0,
    MaxError = 1,
    Psnr = 2,
    Bpv = 3,
    RelError = 4,
    PwRelError = 5
};

/// True for the modes that hold a bound on every voxel through exactly stored outliers.
constexpr bool isBoundedRate(RateMode m) noexcept {
    return m == RateMode::MaxError || m == RateMode::RelError || m == RateMode::PwRelError;
}

/// RateMode::Psnr with target P holds every frame of a series at P - kPsnrToleranceDb or better.
inline constexpr double kPsnrToleranceDb = 0.5;
/// A frame brought back up to that floor is aimed this far above it, so it does not fall short again.
inline constexpr double kPsnrRecoveryMarginDb = 0.1;

/// How a series' frames are predicted: `Block` codes P/B frames by block motion compensation, `None`
/// codes every frame as an I frame.
enum class MotionMode : std::uint8_t { None, Block };

/// Wall time per pipeline stage in milliseconds, summed over every pass of a call (rate-control trials
/// included), so a benchmark can show where encode and decode time goes.
struct CodecProfile {
    double gather = 0;      ///< voxels -> brick arrays in the batch layout, coefficients back to bricks
    double upload = 0;      ///< host -> device copies
    double transform = 0;   ///< lifting kernels (wall time of the launches)
    double download = 0;    ///< device -> host copies
    double entropy = 0;     ///< section (de)coding with the (de)quantisation fused into it, payload building
    double reconstruct = 0; ///< encoder: inverse transform and error check of the rate-control trials
    double assemble = 0;    ///< encoder: brick ranges and the container; decoder: placing bricks, corrections
    double predict = 0;     ///< decoder: P/B frames' motion compensation and the residual added to it
    /// Encoder: the size choices, bricks tried as voxels (palette or raw) against their wavelet payloads
    /// and, for a lossy target, the lossless file it is compared with (docs/codec.md, "Never larger than
    /// lossless").
    double choose = 0;
    double total = 0; ///< the whole call
    int trials = 0;   ///< quantise + reconstruct rounds run by the rate control
    /// Rounds on a sample of bricks (the --psnr estimate of the step, before its full rounds).
    int sampleTrials = 0;
    /// Decoder: bricks read from the file and decoded (uniform ones included), counted where the decoder
    /// takes them, so a distributed reader can prove each rank decodes only the bricks of its extent.
    std::size_t bricks = 0;
};

} // namespace volcl
