// The quantise stage: per-subband steps from a base step, the dead-zone quantiser and its reconstruction as
// the decoder computes it, and the per-subband magnitude limits that keep indices in the coder's range.
#pragma once

#include "wavelet/CodecTypes.hpp"
#include "wavelet/container/VczFormat.hpp"
#include "wavelet/entropy/EntropyCoder.hpp"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace volcl::codec {

inline constexpr double kMaxQuantIndex =
    double(1 << 29); // keeps magnitude classes well inside the coder's range
// Smallest subband step an encoder uses: the quantiser multiplies by 1 / step in float, which must stay
// finite (data of subnormal magnitudes asked for steps of 1e-42; voxels a larger step leaves outside a
// bound are stored exactly).
inline constexpr double kMinStep = 0x1p-120;

// Per-subband steps: a coefficient error e costs about e * gain in the voxel domain, so step = delta / gain.
std::vector<double> subbandSteps(Wavelet w, int levels, double delta);

// Calls fn(z, y, x0, length, step) for every row of every subband of a brick of dims d: per-row loops with
// one step vectorise, per-coefficient callbacks did not.
template <class Fn> void forEachSubbandRow(const VczHeader& h, Dims d, Fn fn) {
    for (const auto& sec : sectionLayout(d, h.levels))
        for (const SubbandBox& b : sec) {
            const double step = h.step(b.level, b.orient);
            for (std::size_t z = b.z0; z < b.z1; ++z)
                for (std::size_t y = b.y0; y < b.y1; ++y)
                    fn(z, y, b.x0, b.x1 - b.x0, step);
        }
}

// Dead-zone quantiser q = sign(c) floor(|c| / step), in float with the reciprocal step (truncation is floor
// for |c| >= 0). Only the encoder quantises and it checks what the decoder will reconstruct from q, so a
// rounding difference at a cell boundary cannot break a bound.
// `zeroBelow` (in steps) is the encoder's dead-zone edge: |c| / step below it codes 0, above it at least
// +-1. The decoder does not know it (it dequantises any index the same way), so an encoder may move it per
// frame to trade bits against error; 1 is the plain floor.
void quantiseRow(const float* in, std::int32_t* out, std::size_t len, double step, double zeroBelow = 1);
// Quantisation indices of a brick of coefficients in rows of `pitch` into `q` (dense brick layout).
void quantiseInto(const VczHeader& h, Dims d, const float* c, std::size_t pitch, std::int32_t* q,
                  double zeroBelow = 1);
// What the decoder will reconstruct from a dense brick of coefficients quantised with the header's steps,
// written to rows of `pitch`: quantised and dequantised row by row, with no index array.
void requantiseInto(const VczHeader& h, Dims d, const float* c, float* dst, std::size_t pitch,
                    double zeroBelow = 1);

// Bit pattern of the largest coefficient magnitude per subband of a dense brick (index as in h.steps),
// merged into `out`. Bit patterns of magnitudes order like the magnitudes (Inf and NaN above all finite
// ones), and an integer max reduction vectorises where a float one does not (NaN semantics).
void subbandMaxAbs(const VczHeader& h, Dims d, const float* c, std::size_t pitch, std::int32_t* out);
// Per-subband maxima over all bricks from subbandMaxAbs's bit patterns (nsub per brick); refuses Inf and
// NaN coefficients (finite voxels beyond the float transform's range): their bit patterns sort above
// every finite magnitude's.
std::vector<double> mergeMaxima(const std::vector<std::int32_t>& brickMax, std::size_t nsub);

} // namespace volcl::codec
