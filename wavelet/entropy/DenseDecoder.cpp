// The dense coder's decoder: per row group, branch-free passes over the magnitude symbols, the signs and the
// raw mantissa bits, in the stream's order. Scalar passes here; the vector ones come from the kernel table
// (DenseKernels.hpp).
#include "wavelet/entropy/DenseKernels.hpp"

#include <algorithm>
#include <array>
#include <cstring>

namespace volcl::entropy {

namespace {

// Decoder: per row group, one branch-free pass decodes the magnitude symbols of every row interleaved (one
// serial chain per row through the previous symbol, overlapping each other), a second the signs of the
// non-zero ones, interleaved likewise, a third their raw mantissa bits.
struct DecodeSide {
    RansDecoder rans;
    RawReader raw;
    DenseModel model;
    std::array<const DecoderTable*, kActivityContexts> tables;
    const PackedTables* packed = nullptr; // set when the vector passes run
    const DenseDecoderKernels* simd = nullptr;

    // The SIMD pass over the columns all rows have (and the last one when the rows differ by one column
    // only, as the subbands of a section do: then the scalar order "x outer, row inner" is unchanged), the
    // rest of each row scalar.
    template <class Step>
    void symbolsVector(const RowJob* jobs, std::size_t nj, WordReader& in, std::uint32_t* st, Step& step) {
        std::size_t minNx = jobs[0].nx, maxNx = jobs[0].nx;
        for (std::size_t i = 1; i < nj; ++i) {
            minNx = std::min(minNx, jobs[i].nx);
            maxNx = std::max(maxNx, jobs[i].nx);
        }
        const std::size_t steps = maxNx - minNx <= 1 ? maxNx : minNx;
        unsigned lastMask = 0;
        for (std::size_t i = 0; i < nj; ++i)
            lastMask |= (jobs[i].nx >= steps ? 1u : 0u) << i;
        simd->symbols(jobs, nj, steps, lastMask, in, st, *packed);
        for (std::size_t i = 0; i < nj; ++i)
            for (std::size_t x = steps; x < jobs[i].nx; ++x)
                step(i, x);
    }

    // Also makes the rows' lists (listNonZero).
    void signsVector(RowJob* jobs, std::size_t nj, WordReader& in, std::uint32_t* st) {
        std::size_t maxCount = 0;
        std::uint32_t counts[kMaxLanes];
        for (std::size_t i = 0; i < nj; ++i) {
            simd->listNonZero(jobs[i]);
            counts[i] = static_cast<std::uint32_t>(jobs[i].count);
            maxCount = std::max(maxCount, jobs[i].count);
        }
        if (maxCount == 0) return;
        simd->signs(jobs, nj, maxCount, counts, in, st, model.signs.data());
    }

    bool rowFlag(unsigned lane, unsigned rctx, std::int32_t* row, std::size_t nx) {
        const bool zero = rans.in.bit(rans.x[lane], model.rows[rctx]) != 0;
        if (zero) std::fill(row, row + nx, 0);
        return zero;
    }
    void rows(RowJob* jobs, std::size_t nj) {
        // Locals that no store through the rows' pointers can alias, so they stay in registers or at least
        // out of the dependency chains.
        WordReader in = rans.in;
        std::uint32_t st[kMaxLanes];
        for (std::size_t i = 0; i < nj; ++i)
            st[i] = rans.x[jobs[i].lane];
        const std::array<const DecoderTable*, kActivityContexts> tab = tables;
        const auto step = [&](std::size_t i, std::size_t x) {
            const RowJob& j = jobs[i];
            // The west symbol as (syms - 1)[x]: syms[x - 1] wraps the unsigned offset at x = 0 (undefined).
            const DecoderTable& t = *tab[static_cast<std::size_t>(
                activityContext(j.activity[x] + kSymbolInfo.west[(j.syms - 1)[x]]))];
            const std::uint32_t s = st[i];
            const unsigned sym = t.lookup[s & (kTableScale - 1)];
            st[i] = in.advance(s, kTableScaleBits, t.start[sym], t.freq[sym]);
            j.syms[x] = static_cast<std::uint8_t>(sym);
        };
        if (packed != nullptr)
            symbolsVector(jobs, nj, in, st, step);
        else
            interleaveSymbols(jobs, nj, step);
        if (simd) {
            signsVector(jobs, nj, in, st);
        } else {
            for (std::size_t i = 0; i < nj; ++i) {
                RowJob& j = jobs[i];
                std::fill(j.mag, j.mag + j.nx, 0);
                std::fill(j.sgn, j.sgn + j.nx, 0);
                std::size_t count = 0;
                for (std::size_t x = 0; x < j.nx; ++x) {
                    j.nonZero[count] = static_cast<std::uint32_t>(x);
                    count += j.syms[x] != 0;
                }
                j.count = count;
                j.withRawBits = j.nonZero;
                j.rawCount = count;
            }
            interleaveSigns(jobs, nj, [&](std::size_t i, std::size_t n) {
                const RowJob& j = jobs[i];
                const std::size_t x = j.nonZero[n];
                const unsigned negative = in.bit(st[i], model.signs[j.signBase[x] + (j.sgn - 1)[x]]);
                j.sgn[x] = static_cast<std::uint8_t>(1 + negative);
            });
        }
        for (std::size_t i = 0; i < nj; ++i)
            rans.x[jobs[i].lane] = st[i];
        rans.in = in;
        RawReader b = raw;
        for (std::size_t i = 0; i < nj; ++i) {
            RowJob& j = jobs[i];
            for (std::size_t n = 0; n < j.rawCount; ++n) {
                const std::size_t x = j.withRawBits[n] & kListX;
                const unsigned sym = j.syms[x];
                j.mag[x] = kSymbolInfo.base[sym] | b.get(kSymbolInfo.rawBits[sym]);
            }
            for (std::size_t x = 0; x < j.nx; ++x) {
                const std::uint32_t negative = 0u - static_cast<std::uint32_t>(j.sgn[x] >> 1);
                j.row[x] = static_cast<std::int32_t>((j.mag[x] ^ negative) - negative);
            }
        }
        raw = b;
    }
};

} // namespace

void decodeDense(std::span<const std::uint8_t> in, std::span<std::int32_t> coeffs, Dims brick,
                 const std::vector<std::vector<SubbandBox>>& layout, std::size_t s, const char* what) {
    if (in.empty() || in[0] > kAllZero) corrupt(what, "invalid dense section header");
    if (in[0] == kAllZero) {
        if (in.size() != 1) corrupt(what, "unexpected bytes after an all-zero section");
        for (const SubbandBox& b : layout[s])
            for (std::size_t z = b.z0; z < b.z1; ++z)
                for (std::size_t y = b.y0; y < b.y1; ++y) {
                    std::int32_t* row = coeffs.data() + (z * brick.y + y) * brick.x;
                    std::fill(row + b.x0, row + b.x1, 0);
                }
        return;
    }
    const bool useContexts = in[0] == kContextTables;
    const int ntables = useContexts ? kActivityContexts : 1;
    // Tables a valid stream never selects decode everything as symbol 0 at no cost; a corrupted stream
    // that reaches them fails the final state check.
    // Contexts without a table point to one that decodes symbol 0 at no cost: a valid stream never uses
    // them, a corrupted one that does fails the final state check. Only sent tables are built (small
    // sections would otherwise pay for all 25).
    static const DecoderTable kUnused = [] {
        DecoderTable t;
        t.freq[0] = kTableScale;
        std::memset(t.lookup, 0, sizeof t.lookup);
        return t;
    }();
    std::vector<DecoderTable> tables;
    tables.reserve(static_cast<std::size_t>(ntables));
    std::array<const DecoderTable*, kActivityContexts> tablePtr;
    tablePtr.fill(&kUnused);
    // Table bits: a byte-aligned bit stream whose length follows from its content.
    BitReader tb(in.subspan(1));
    std::size_t tableBitCount = 0;
    for (int t = 0; t < ntables; ++t) {
        const int nsym = static_cast<int>(tb.get(6));
        tableBitCount += 6;
        if (nsym > kSymbols) corrupt(what, "invalid symbol table");
        if (nsym == 0) continue;
        std::array<std::uint8_t, kSymbols> q{};
        for (int i = 0; i < nsym; ++i)
            q[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(tb.get(6));
        tableBitCount += 6 * static_cast<std::size_t>(nsym);
        SymbolTable st;
        if (!buildTable(q, nsym, st)) corrupt(what, "empty symbol table");
        DecoderTable& d = tables.emplace_back();
        for (std::size_t sym = 0; sym < kSymbols; ++sym) {
            d.start[sym] = st.start[sym];
            d.freq[sym] = st.freq[sym];
            std::memset(d.lookup + st.start[sym], static_cast<int>(sym), st.freq[sym]);
        }
        if (useContexts)
            tablePtr[static_cast<std::size_t>(t)] = &d;
        else
            tablePtr.fill(&d);
    }
    const std::size_t tableBytes = (tableBitCount + 7) / 8;
    if (in.size() - 1 < tableBytes) corrupt(what, "truncated dense section");
    std::size_t head = 1 + tableBytes;
    std::uint64_t n = 0;
    if (getVarint(in, head, n, 5) != VarintStatus::Ok) corrupt(what, "truncated dense section");
    if (n > in.size() - head) corrupt(what, "entropy section sizes exceed the brick");
    const std::vector<std::uint8_t> ransBytes = RansDecoder::padded(in.subspan(head, n));
    const std::vector<std::uint8_t> rawBytes = RawReader::padded(in.subspan(head + n));
    DecodeSide side{RansDecoder(ransBytes, n, static_cast<int>(layout[s].size())),
                    RawReader(rawBytes, in.size() - head - n),
                    {},
                    tablePtr,
                    nullptr};
    // Entries of the SIMD decoder's non-zero lists hold x in 24 bits.
    const DenseDecoderKernels* kernels = denseDecoderKernels();
    if (kernels && brick.x <= kListX) {
        // Reused across sections: 25 tables are 200 KB, which malloc would map and unmap every time.
        thread_local PackedTables pt;
        pt.entries.resize((tables.size() + 1) * kTableScale + 2);
        for (std::uint32_t slot = 0; slot < kTableScale; ++slot)
            pt.entries[slot] = packedEntry(slot, kTableScale, 0);
        std::fill(pt.offset, pt.offset + 32, 0u);
        for (std::size_t b = 0; b < tables.size(); ++b) {
            const DecoderTable& d = tables[b];
            std::uint32_t* e = pt.entries.data() + (b + 1) * kTableScale;
            for (std::uint32_t sym = 0; sym < kSymbols; ++sym)
                for (std::uint32_t k = 0; k < d.freq[sym]; ++k)
                    e[d.start[sym] + k] = packedEntry(k, d.freq[sym], sym);
        }
        for (std::size_t c = 0; c < kActivityContexts; ++c)
            if (tablePtr[c] != &kUnused)
                pt.offset[c] = static_cast<std::uint32_t>(tablePtr[c] - tables.data() + 1) * kTableScale;
        side.packed = &pt;
        side.simd = kernels;
    }
    SectionWalker walker{brick, layout, s};
    walker.run(coeffs.data(), side);
    if (!side.rans.exact()) corrupt(what, "entropy stream does not end where its size says");
    if (!side.raw.exact()) corrupt(what, "raw bit stream length mismatch");
}

} // namespace volcl::entropy
