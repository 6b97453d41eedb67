// The dense coder's model, shared by its encoder and decoder: magnitude symbols and activity contexts,
// symbol tables, adaptive models, and the section walker that visits a section's subbands row by row.
#pragma once

#include "wavelet/entropy/EntropyCoder.hpp"
#include "wavelet/entropy/Rans.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <climits>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace volcl::entropy {

// ------------------------------------------------------------------------------ dense model

// Magnitude symbol: 0 and 1 stand for themselves; a magnitude of bit length n >= 2 is 2(n-1) + its top
// mantissa bit, and its n-2 lower bits go raw. Magnitudes below 2^30 give symbols below 60.
inline constexpr int kSymbols = 60;
inline constexpr int kMaxBitLength = 30;
// Activity contexts: half-octave classes of 4(N+U) + (NW+NE+UW+UE+UN) + 2 parent + 4 W (magnitudes of the
// neighbours in the previous row and slice, of the parent one level coarser, and the smallest magnitude of
// the previous coefficient's symbol). W makes each row a serial chain in the decoder (worth about 1 % on
// ch2better); the chains of the section's subbands are decoded interleaved so that they overlap.
inline constexpr int kActivityContexts = 25;
inline constexpr int kSignContexts = 27 * 8; // signs of W, N, U (negative, zero, positive) per orientation
inline constexpr int kTableBitsPerEntry = 6;

// Without jumps (the encoder's symbol loop mispredicted on them): k = floor(log2 max(u, 1)) and
// sh = max(k - 1, 0); u >> sh is the top two bits of u (u >= 2), or u itself (u < 2).
inline int symbolOf(std::uint32_t u) {
    const int k = 31 - std::countl_zero(u | 1u);
    const int sh = k - (k != 0 ? 1 : 0);
    return 2 * sh + static_cast<int>(u >> sh);
}
// Per symbol: how many raw mantissa bits follow it, its magnitude with those bits zero (base), and 4 base,
// the previous coefficient's share of the activity (its smallest magnitude stands in for it, because its
// raw bits are read in a later pass). Tables instead of arithmetic: shorter chains, no branches.
struct SymbolInfo {
    std::array<std::uint8_t, 64> rawBits{};
    alignas(64) std::array<std::uint32_t, 64> base{}; // aligned for the SIMD decoder's permutations
    std::array<std::uint32_t, 64> west{};
};
inline constexpr SymbolInfo kSymbolInfo = [] {
    SymbolInfo t;
    for (unsigned sym = 0; sym < kSymbols; ++sym) {
        const unsigned n = sym < 2 ? 0 : sym / 2 - 1;
        t.rawBits[sym] = static_cast<std::uint8_t>(n);
        t.base[sym] = sym < 2 ? sym : (2u | (sym & 1u)) << n;
        t.west[sym] = 4 * t.base[sym];
    }
    return t;
}();
// 0 for a = 0, 1 for a = 1, then two classes per octave (the bit below the leading one), capped at 24,
// which every a >= 2^11.5 reaches: a 4 KB table indexed by min(a, 4095) (three instructions).
inline constexpr std::array<std::uint8_t, 4096> kActivityClass = [] {
    std::array<std::uint8_t, 4096> t{};
    for (std::uint32_t a = 1; a < 4096; ++a) {
        int n = 0;
        while ((a >> n) > 1)
            ++n; // a has bit length n + 1
        const int half = n > 0 ? static_cast<int>((a >> (n - 1)) & 1u) : 0;
        t[a] = static_cast<std::uint8_t>(std::min(2 * n + 1 + half, kActivityContexts - 1));
    }
    return t;
}();
inline int activityContext(std::uint32_t a) {
    return kActivityClass[std::min<std::uint32_t>(a, 4095)];
}
inline unsigned signClass(std::int32_t v) {
    return static_cast<unsigned>(v > 0) + 2 * static_cast<unsigned>(v < 0);
}

// Frequencies (sum kTableScale, every present symbol >= 1) rebuilt from the quantised log weights that the
// section stores; encoder and decoder run this same code, so they agree bit for bit.
struct SymbolTable {
    std::array<std::uint16_t, kSymbols> start{}, freq{};
};

// The decoder's view of one table: slot-to-symbol lookup and the symbols' slot ranges, contiguous.
struct DecoderTable {
    std::uint16_t start[64] = {}, freq[64] = {};
    std::uint8_t lookup[kTableScale];
};

// q = 0: absent; else weight 2^((q - 1) / 4) (times 1024, integers so that every platform agrees), q < 64.
inline std::uint64_t weightOf(int q) {
    static constexpr std::array<std::uint64_t, 4> kQuarterOctave = {1024, 1218, 1448, 1722};
    return kQuarterOctave[static_cast<std::size_t>((q - 1) % 4)] << ((q - 1) / 4);
}

/// Frequencies from the quantised log weights q[0..nsym); false when every weight is zero.
bool buildTable(const std::array<std::uint8_t, kSymbols>& q, int nsym, SymbolTable& t);

// Quantised log weight of a count: 1 + round(4 log2(count / total * 2^14)), clamped to 1..63.
inline std::uint8_t quantiseCount(std::uint64_t count, std::uint64_t total) {
    if (count == 0) return 0;
    const double l = std::log2(double(count) / double(total)) + 14.0;
    return static_cast<std::uint8_t>(std::clamp<long>(1 + std::lround(4.0 * l), 1, 63));
}

// Adaptive state shared by encoder and decoder.
struct DenseModel {
    std::array<BitModel, 4 * 8>
        rows; // row "all zero" flag: (previous y row zero, previous z row zero) x orientation
    std::array<BitModel, kSignContexts> signs;
};

// x in a RowJob::nonZero entry (x < 2^24; signBase, below 256, may sit above it).
inline constexpr std::uint32_t kListX = 0xFFFFFF;

// One non-zero row of one subband, handed by the walker to a side with its contexts precomputed.
struct RowJob {
    unsigned lane; // the subband's index in its section, which is also its rANS state
    std::size_t nx;
    const std::uint32_t* activity; // per x: neighbour and parent part of the magnitude context
    const std::uint16_t* signBase; // per x: neighbour part of the sign context
    std::int32_t* row;             // the row in the brick
    std::uint32_t* mag;            // its magnitudes in the zero-padded slice copy (mag[-1] and mag[nx] are 0)
    std::uint8_t* sgn;             // its sign classes (signClass) likewise
    std::uint8_t* syms;            // magnitude symbol per x (syms[-1] is 0: the previous symbol of x = 0)
    std::uint32_t* nonZero;        // scratch: x of the non-zero coefficients in order, `count` of them (the
                                   // SIMD decoder keeps signBase[x] in bits 24-31: read x as & kListX)
    std::uint32_t* withRawBits;    // SIMD decoder's scratch: the entries of nonZero with raw bits, `rawCount`
    std::size_t count;
    std::size_t rawCount;
};

// Where the encoder puts row `row`'s pending symbol events among the `rows` rows of a group, in the
// decoder's order (interleaveSymbols): x < minNx at events[x * rows + row], the other x at events[tail + x]
// (after the interleaved part and the ends of the rows before it).
struct SymbolSlots {
    RansEvent* events;
    std::size_t rows, row, minNx, tail;
};

// Walks section s row by row: at each (slice, row) position it takes that row of every subband of the
// section (they are independent given the previous section), codes their "all zero" flags, computes each
// non-zero row's magnitude and sign contexts from the previous row, the previous slice and the parent (no
// dependence on the row itself, so these loops have no serial chain), then hands the non-zero rows to
// side.rows, which interleaves them. Neighbours come from zero-padded copies of the current and the
// previous slice of each subband, so no loop has boundary tests.
struct SectionWalker {
    Dims brick;
    const std::vector<std::vector<SubbandBox>>& layout;
    std::size_t s;

    struct Band {
        const SubbandBox* box = nullptr;
        const SubbandBox* parent = nullptr;
        std::size_t nx = 0, ny = 0, nz = 0, pitch = 0;
        // Slice buffers of magnitudes and sign classes: row 0 is the zero row above y0; row r+1 holds row
        // y0+r; columns 0 and nx+1 are zero. Magnitudes are kept apart so that the context loops are plain
        // sums that vectorise.
        std::vector<std::uint32_t> cur, prev;
        std::vector<std::uint8_t> curSign, prevSign;
        std::size_t parentY = SIZE_MAX, parentZ = SIZE_MAX; // the parent row held in parentRow
        std::vector<std::uint8_t> rowZero, prevRowZero;
        std::vector<std::uint32_t> parentRow, activity, nonZero, withRawBits;
        std::vector<std::uint16_t> signBase;
        std::vector<std::uint8_t> syms;
    };

    template <class Side> void run(std::int32_t* c, Side& side) {
        const std::size_t sx = brick.x, sxy = brick.x * brick.y;
        const std::size_t nb = layout[s].size();
        std::array<Band, kMaxLanes> bands;
        std::size_t maxNy = 0, maxNz = 0;
        for (std::size_t k = 0; k < nb; ++k) {
            Band& b = bands[k];
            b.box = &layout[s][k];
            if (b.box->level > 0 && s >= 2)
                for (const SubbandBox& pb : layout[s - 1])
                    if (pb.orient == b.box->orient) b.parent = &pb;
            b.nx = b.box->x1 - b.box->x0;
            b.ny = b.box->y1 - b.box->y0;
            b.nz = b.box->z1 - b.box->z0;
            b.pitch = b.nx + 2;
            b.cur.assign((b.ny + 1) * b.pitch, 0);
            b.prev.assign((b.ny + 1) * b.pitch, 0);
            // 4 bytes more: the SIMD sign pass stores 4 bytes per sign (zeros after it, see signsSimd).
            b.curSign.assign((b.ny + 1) * b.pitch + 4, 0);
            b.prevSign.assign((b.ny + 1) * b.pitch + 4, 0);
            b.rowZero.assign(b.ny, 1);
            b.prevRowZero.assign(b.ny, 1);
            b.parentRow.assign(b.nx, 0);
            b.activity.assign(b.nx, 0);
            b.nonZero.assign(b.nx + 16, 0); // the SIMD decoder stores 16 entries at a time
            b.withRawBits.assign(b.nx + 16, 0);
            b.signBase.assign(b.nx, 0);
            b.syms.assign(b.nx + 4, 0); // syms[0] stays 0: the symbol before x = 0; 3 bytes for 4-byte stores
            maxNy = std::max(maxNy, b.ny);
            maxNz = std::max(maxNz, b.nz);
        }
        for (std::size_t zi = 0; zi < maxNz; ++zi) {
            for (std::size_t r = 0; r < maxNy; ++r) {
                std::array<RowJob, kMaxLanes> jobs;
                std::size_t nj = 0;
                for (std::size_t k = 0; k < nb; ++k) {
                    Band& b = bands[k];
                    if (zi >= b.nz || r >= b.ny) continue;
                    const SubbandBox& box = *b.box;
                    const std::size_t nx = b.nx, pitch = b.pitch, z = box.z0 + zi;
                    std::int32_t* row = c + z * sxy + (box.y0 + r) * sx + box.x0;
                    std::uint32_t* m = b.cur.data() + (r + 1) * pitch + 1;
                    std::uint8_t* sg = b.curSign.data() + (r + 1) * pitch + 1;
                    const auto orient = static_cast<unsigned>(box.orient);
                    const unsigned rctx =
                        orient * 4 + (r > 0 ? b.rowZero[r - 1] : 1u) + 2u * b.prevRowZero[r];
                    const bool zero = side.rowFlag(static_cast<unsigned>(k), rctx, row, nx);
                    b.rowZero[r] = zero;
                    if (zero) {
                        std::fill(m, m + nx, 0);
                        std::fill(sg, sg + nx, 0);
                        continue;
                    }
                    std::uint32_t* parentRow = b.parentRow.data();
                    if (b.parent) {
                        // Rows 2k and 2k+1 share their parent row.
                        const SubbandBox& p = *b.parent;
                        const std::size_t pz = std::min(p.z0 + zi / 2, p.z1 - 1);
                        const std::size_t py = std::min(p.y0 + r / 2, p.y1 - 1);
                        if (pz != b.parentZ || py != b.parentY) {
                            // Child x has parent x / 2, clamped to the parent's last column.
                            const std::int32_t* prow = c + pz * sxy + py * sx + p.x0;
                            const std::size_t pairs = std::min(nx / 2, p.x1 - p.x0);
                            for (std::size_t px = 0; px < pairs; ++px)
                                parentRow[2 * px] = parentRow[2 * px + 1] = 2 * magnitude(prow[px]);
                            for (std::size_t x = 2 * pairs; x < nx; ++x)
                                parentRow[x] = 2 * magnitude(prow[std::min(x / 2, p.x1 - p.x0 - 1)]);
                            b.parentZ = pz;
                            b.parentY = py;
                        }
                    }
                    const std::uint32_t* n = m - pitch;
                    const std::uint32_t* u = b.prev.data() + (r + 1) * pitch + 1;
                    const std::uint32_t* un = u - pitch;
                    std::uint32_t* activity = b.activity.data();
                    // The west neighbours through pointers to x - 1: `n[x - 1]` with an unsigned x wraps the
                    // offset at x = 0 (undefined, reported by clang's UBSan) though the address is the border.
                    const std::uint32_t* nw = n - 1;
                    const std::uint32_t* uw = u - 1;
                    for (std::size_t x = 0; x < nx; ++x)
                        activity[x] =
                            4 * (n[x] + u[x]) + nw[x] + n[x + 1] + uw[x] + u[x + 1] + un[x] + parentRow[x];
                    const std::uint8_t* ns = sg - pitch;
                    const std::uint8_t* us = b.prevSign.data() + (r + 1) * pitch + 1;
                    const auto sctx0 = static_cast<std::uint16_t>(orient * 27);
                    std::uint16_t* signBase = b.signBase.data();
                    for (std::size_t x = 0; x < nx; ++x)
                        signBase[x] = static_cast<std::uint16_t>(sctx0 + 3 * ns[x] + 9 * us[x]);
                    jobs[nj++] = {static_cast<unsigned>(k),
                                  nx,
                                  activity,
                                  signBase,
                                  row,
                                  m,
                                  sg,
                                  b.syms.data() + 1,
                                  b.nonZero.data(),
                                  b.withRawBits.data(),
                                  0,
                                  0};
                }
                if (nj > 0) side.rows(jobs.data(), nj);
            }
            for (std::size_t k = 0; k < nb; ++k)
                if (zi < bands[k].nz) {
                    std::swap(bands[k].cur, bands[k].prev);
                    std::swap(bands[k].curSign, bands[k].prevSign);
                    std::swap(bands[k].rowZero, bands[k].prevRowZero);
                }
        }
    }
};

// The order in which the scalar decoder visits the coefficients of a row group, which is the stream's
// decision order (the SIMD decoder steps through it column by column, and the encoder writes its events
// straight into it): magnitude symbols interleaved across the rows (x outer, row inner) up to
// the shortest row, then the rest of each row; then signs of the non-zero coefficients interleaved the
// same way (their n-th non-zero coefficient each); then each row's raw mantissa bits in turn.
template <class Step> void interleaveSymbols(const RowJob* jobs, std::size_t nj, Step&& step) {
    std::size_t minNx = jobs[0].nx;
    for (std::size_t i = 1; i < nj; ++i)
        minNx = std::min(minNx, jobs[i].nx);
    for (std::size_t x = 0; x < minNx; ++x)
        for (std::size_t i = 0; i < nj; ++i)
            step(i, x);
    for (std::size_t i = 0; i < nj; ++i)
        for (std::size_t x = minNx; x < jobs[i].nx; ++x)
            step(i, x);
}
/// step(i, n) for the n-th non-zero coefficient of row i.
template <class Step> void interleaveSigns(const RowJob* jobs, std::size_t nj, Step&& step) {
    std::size_t maxCount = 0;
    for (std::size_t i = 0; i < nj; ++i)
        maxCount = std::max(maxCount, jobs[i].count);
    for (std::size_t n = 0; n < maxCount; ++n)
        for (std::size_t i = 0; i < nj; ++i)
            if (n < jobs[i].count) step(i, n);
}

// The decoder's per-slot view of all tables of a section for the SIMD pass: per table 2048 entries of
// (slot - start) | freq << 11 | symbol << 23 (one gather gives the symbol and the rANS step), blocks of
// 2048 one after the other (block 0 decodes symbol 0 at no cost, for contexts without a table), and per
// activity class the offset of its block in entries (32 entries: the permutation reads two registers).
struct PackedTables {
    std::vector<std::uint32_t> entries;
    alignas(64) std::uint32_t offset[32] = {};
};

inline constexpr std::uint32_t packedEntry(std::uint32_t bias, std::uint32_t freq, std::uint32_t sym) {
    return bias | freq << 11 | sym << 23;
}

// Section layout (dense): u8 mode (0: one table, 1: one table per activity class, 2: every coefficient is
// zero and nothing follows), the tables (bit packed: per table 6 bits nsym, then nsym 6-bit quantised log
// weights; nsym 0 = unused table), varint size of the rANS stream, the rANS stream (varints of the final
// states minus 2^16, one per subband of the section, then 16-bit words), the raw mantissa bits.
inline constexpr std::uint8_t kOneTable = 0, kContextTables = 1, kAllZero = 2;

/// Appends dense section `s` of `coeffs` (rows of brick.x elements) to `out`.
void encodeDense(std::span<const std::int32_t> coeffs, Dims brick,
                 const std::vector<std::vector<SubbandBox>>& layout, std::size_t s,
                 std::vector<std::uint8_t>& out);
/// Decodes dense section `s` into `coeffs`; throws IoError naming `what` on inconsistent data.
void decodeDense(std::span<const std::uint8_t> in, std::span<std::int32_t> coeffs, Dims brick,
                 const std::vector<std::vector<SubbandBox>>& layout, std::size_t s, const char* what);

} // namespace volcl::entropy
