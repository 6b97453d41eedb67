// The set-partitioning (SPECK-style) section coder's shared model: octree sets over a section's subbands,
// the decision contexts, and the coder's entry points (encoder and decoder live in their own files).
//
// What it codes: the same quantised integers as the dense coder, losslessly. Each set (a box of the brick's
// coefficient array) has a bit length, that of its largest magnitude. A set's children (its box halved
// along every axis longer than one) have bit lengths at most their parent's; each child's is coded as
// SPECK's sorting pass would find it, one "significant at plane n" decision per plane from the parent's top
// plane down until the first yes. Since every plane down to the quantisation step is coded, the decisions
// are SPECK's, only visited depth first instead of plane by plane (the order changes nothing in the integers
// and little in the adaptive models). A significant single coefficient then gives its sign and the bits
// below its leading one. The last child of a set needs no decision at its parent's top plane when none of
// its siblings reached it (one of them must). The section's subbands are the children of the section.
// Decisions are adaptive binary events on one rANS state (wavelet/entropy/Rans.hpp).
//
// Section layout: u8 bit length P of the section's largest magnitude (0: every coefficient is zero, and
// nothing follows), then the rANS stream (putStream: the final state as a varint, then 16-bit words).
#pragma once

#include "wavelet/entropy/EntropyCoder.hpp"
#include "wavelet/entropy/Rans.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace volcl::entropy {

/// A set: a box of the coefficient array, [x0, x0+nx) x [y0, y0+ny) x [z0, z0+nz).
struct SpeckSet {
    std::uint32_t x0 = 0, y0 = 0, z0 = 0, nx = 1, ny = 1, nz = 1;
    std::size_t count() const noexcept { return std::size_t(nx) * ny * nz; }
    bool single() const noexcept { return nx == 1 && ny == 1 && nz == 1; }
};

/// The children of a set with more than one coefficient: its box halved along each axis longer than one
/// (first half the larger), ordered x fastest, then y, then z. Returns how many (2, 4 or 8). `slot[i]` is
/// child i's octant (bit 0: upper half in x, bit 1 in y, bit 2 in z).
inline int splitSet(const SpeckSet& s, SpeckSet* kids, int* slot) {
    const std::uint32_t hx = (s.nx + 1) / 2, hy = (s.ny + 1) / 2, hz = (s.nz + 1) / 2;
    int n = 0;
    for (int o = 0; o < 8; ++o) {
        const bool ux = o & 1, uy = o & 2, uz = o & 4;
        if ((ux && s.nx == 1) || (uy && s.ny == 1) || (uz && s.nz == 1)) continue;
        SpeckSet k;
        k.x0 = s.x0 + (ux ? hx : 0);
        k.nx = s.nx == 1 ? 1 : (ux ? s.nx - hx : hx);
        k.y0 = s.y0 + (uy ? hy : 0);
        k.ny = s.ny == 1 ? 1 : (uy ? s.ny - hy : hy);
        k.z0 = s.z0 + (uz ? hz : 0);
        k.nz = s.nz == 1 ? 1 : (uz ? s.nz - hz : hz);
        kids[n] = k;
        slot[n] = o;
        ++n;
    }
    return n;
}

inline SpeckSet setOf(const SubbandBox& b) {
    return {static_cast<std::uint32_t>(b.x0),        static_cast<std::uint32_t>(b.y0),
            static_cast<std::uint32_t>(b.z0),        static_cast<std::uint32_t>(b.x1 - b.x0),
            static_cast<std::uint32_t>(b.y1 - b.y0), static_cast<std::uint32_t>(b.z1 - b.z0)};
}

// Significance contexts: the set's size class (one coefficient, then 2-8, 9-64, 65-512, 513-4096, more),
// how many planes below the parent's top plane the decision is (0, 1, 2+), and how many earlier siblings
// reached the parent's top plane (0, 1, 2+).
inline constexpr int kSpeckSizeClasses = 6, kSpeckGaps = 3, kSpeckSiblings = 3;
inline constexpr int kSpeckRefineContexts = 3; // bit just below the leading one, the next, the rest
inline int speckSizeClass(std::size_t count) {
    if (count == 1) return 0;
    const int bits = std::bit_width(count - 1); // 1..
    return std::min(kSpeckSizeClasses - 1, (bits + 2) / 3);
}
inline int speckContext(int sizeClass, int gap, int siblingsAtTop) {
    return (sizeClass * kSpeckGaps + std::min(gap, kSpeckGaps - 1)) * kSpeckSiblings +
           std::min(siblingsAtTop, kSpeckSiblings - 1);
}

/// The step after a member's bit length `b` is known, the same on both sides: counts it towards the
/// siblings at the parent's `top`, then a significant member gives its coefficient or its children.
template <class Side> void descend(Side& side, const SpeckSet& s, int b, int top, int& atTop) {
    atTop += b == top;
    if (b == 0) return;
    if (s.single())
        side.coefficient(s, b);
    else
        side.children(s, b);
}

/// encodeSectionSmallest tries set partitioning only on sections whose dense coding takes fewer bits per
/// coefficient than this. Measured over the sections of hydrogen, Isabel step 30 (40 / 60 dB) and ch2better
/// (50 dB), 834 sections under 2 bits: below 0.2 it won 94 of 440 sections and 4.1 % of their bytes (7 % below
/// 0.1); from 0.3 to 2 it won 144 of 394 and 0.1 %, for 3.6x the dense coder's entropy time on ch2better.
inline constexpr double kSpeckTryBitsPerCoefficient = 0.25;

/// The adaptive models of one section (reset per section: sections are coded independently).
struct SpeckModels {
    std::array<BitModel, kSpeckSizeClasses * kSpeckGaps * kSpeckSiblings> significance{};
    BitModel sign{};
    std::array<BitModel, kSpeckRefineContexts> refine{};
};

/// Appends section `s` of `coeffs` (rows of brick.x elements) coded by set partitioning to `out`.
/// Magnitudes must stay below 2^30, as for the dense coder.
void encodeSpeck(std::span<const std::int32_t> coeffs, Dims brick, const std::vector<SubbandBox>& bands,
                 std::vector<std::uint8_t>& out);

/// Decodes a section written by encodeSpeck into its subbands of `coeffs`; IoError naming `what` when the
/// stream is inconsistent (never reads outside `in` or the subbands).
void decodeSpeck(std::span<const std::uint8_t> in, std::span<std::int32_t> coeffs, Dims brick,
                 const std::vector<SubbandBox>& bands, const char* what);

} // namespace volcl::entropy
