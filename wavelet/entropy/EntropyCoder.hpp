// Entropy coding of quantised wavelet coefficients: subband layout and section coding by the dense
// context-modelled rANS coder or the fast zstd-over-byte-planes coder (wavelet/entropy/). Internal to the
// codec.
#pragma once

#include "core/Volume.hpp"
#include "wavelet/CodecTypes.hpp"

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace volcl {

/// One subband of a brick in the Mallat layout: voxel box [x0,x1) x [y0,y1) x [z0,z1) of the brick.
struct SubbandBox {
    std::size_t x0 = 0, x1 = 0, y0 = 0, y1 = 0, z0 = 0, z1 = 0;
    int level = 0;  ///< 0 for the low band, else 1 (finest) .. L (coarsest)
    int orient = 0; ///< bit 0: high along x, bit 1: high along y, bit 2: high along z (0 for the low band)
    std::size_t count() const noexcept { return (x1 - x0) * (y1 - y0) * (z1 - z0); }
};

/// Index of a subband in per-subband tables such as VczHeader::steps: 0 for the low band, then 7 per level
/// (1 = finest), by orientation 1..7.
constexpr std::size_t subbandIndex(int level, int orient) noexcept {
    return level == 0 ? 0 : 1 + 7 * std::size_t(level - 1) + std::size_t(orient - 1);
}

/// Sections of a brick transformed with `levels` levels: section 0 holds the low band, section j >= 1 the
/// non-empty detail subbands of level levels-j+1. Decoding sections 0..levels-k gives the level-k image.
std::vector<std::vector<SubbandBox>> sectionLayout(Dims brick, int levels);

/// Appends the coded section `s` of the coefficient array (brick dims, x fastest) to `out`.
/// Magnitudes must stay below 2^30 (the caller guarantees it).
void encodeSection(std::span<const std::int32_t> coeffs, Dims brick,
                   const std::vector<std::vector<SubbandBox>>& layout, std::size_t s, EntropyMode mode,
                   std::vector<std::uint8_t>& out);

/// Like encodeSection, and in dense mode the section is also coded by set partitioning
/// (wavelet/entropy/SpeckModel.hpp) when its dense coding is sparse enough for that to have a chance
/// (below kSpeckTryBitsPerCoefficient); the smaller coding is appended. Returns true when it is the
/// set-partitioning one (the payload records it per section: decodeSection's `setPartitioned`).
bool encodeSectionSmallest(std::span<const std::int32_t> coeffs, Dims brick,
                           const std::vector<std::vector<SubbandBox>>& layout, std::size_t s,
                           EntropyMode mode, std::vector<std::uint8_t>& out);

/// Reconstruction of a row of quantisation indices: (|q| + bias) * step with the sign of q, 0 for q = 0.
/// The one formula of the codec: the encoder checks its bounds on what this returns, the decoder writes it.
/// `in` may be `out` reinterpreted (in place): each element is read before it is overwritten.
inline void dequantiseRow(const std::int32_t* in, float* out, std::size_t len, double step, double bias) {
    // Float arithmetic and selects instead of branches, so that the loop runs 4 lanes wide on baseline
    // x86-64 (double took two conversions per lane); |q| <= 2^29, so the negation is safe.
    const float s = static_cast<float>(step), bs = static_cast<float>(bias * step);
    for (std::size_t i = 0; i < len; ++i) {
        const std::int32_t v = in[i];
        const float m = static_cast<float>(v < 0 ? -v : v) * s + bs;
        const float r = v < 0 ? -m : m;
        out[i] = v == 0 ? 0.0f : r;
    }
}

/// Dequantisation applied while a section is decoded: `steps` indexed by subbandIndex (VczHeader::steps).
struct Dequantiser {
    std::span<const double> steps;
    double bias = 0.5;
    double step(const SubbandBox& b) const { return steps[subbandIndex(b.level, b.orient)]; }
};

/// Decodes section `s` from `in` into its subbands of `coeffs` (earlier sections must be decoded: they
/// give the parent context). `setPartitioned`: the section was coded by set partitioning instead of by
/// `mode`. Throws IoError naming `what` when the data are inconsistent.
void decodeSection(std::span<const std::uint8_t> in, std::span<std::int32_t> coeffs, Dims brick,
                   const std::vector<std::vector<SubbandBox>>& layout, std::size_t s, EntropyMode mode,
                   const char* what, bool setPartitioned = false);

/// Decodes sections 0 .. sections.size()-1 of a brick (as decodeSection). With `dq` the coefficients come
/// out dequantised, as float bit patterns in `coeffs`: fast mode dequantises each row as it decodes it;
/// dense mode after the last section (decoded coefficients are the next section's context). Bit s of
/// `setPartitioned` marks section s as coded by set partitioning (dense mode only).
void decodeSections(std::span<const std::span<const std::uint8_t>> sections, std::span<std::int32_t> coeffs,
                    Dims brick, const std::vector<std::vector<SubbandBox>>& layout, EntropyMode mode,
                    const char* what, const Dequantiser* dq, std::uint32_t setPartitioned = 0);

} // namespace volcl
