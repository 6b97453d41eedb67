// The dense coder's encoder: the walker's rows become rANS events (adaptive row flags and signs at once,
// magnitude symbols pending until the section's tables exist), then the tables, the backward pass and the
// section bytes. Scalar passes here; the vector ones come from the kernel table (DenseKernels.hpp).
#include "wavelet/entropy/DenseKernels.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace volcl::entropy {

namespace {

// Encoder pass 1: adaptive decisions become events at once; magnitude symbols are recorded as pending
// events (scaleBits 0, start = context * 64 + symbol) and resolved once the tables exist.
struct EncodeSide {
    DenseModel model;
    EncoderScratch& scratch = encoderScratch();
    // Room for the worst case (a row flag per row, a symbol and a sign per coefficient), filled at next.
    RansEvent* next = nullptr;
    // Symbol counts per context * 64 + symbol, in two halves (see rows()), summed by encodeDense().
    std::array<std::array<std::uint32_t, kActivityContexts * 64>, 2> counts{};
    RawWriter raw{scratch.raw};
    std::uintptr_t previousRow[kMaxLanes] = {}; // per lane, the row of its last row flag
    const DenseEncoderKernels* simd = nullptr;  // vector passes instead of the scalar ones

    void binary(unsigned lane, BitModel& m, unsigned bit) { *next++ = binaryEvent(m, bit, lane); }
    bool rowFlag(unsigned lane, unsigned rctx, const std::int32_t* row, std::size_t nx) {
        // The lane's next row is likely as far on as this one from its previous row: fetch it now (the
        // walker visits up to 7 subbands' rows in turn, a pattern the hardware prefetchers miss).
        const auto at = reinterpret_cast<std::uintptr_t>(row);
        const std::uintptr_t ahead = at + (at - previousRow[lane]);
        previousRow[lane] = at;
        for (std::uintptr_t line = 0; line < 4 * nx; line += 64)
            __builtin_prefetch(reinterpret_cast<const void*>(ahead + line));
        bool zero = true;
        if (simd)
            zero = simd->rowIsZero(row, nx);
        else
            for (std::size_t x = 0; x < nx && zero; ++x)
                zero = row[x] == 0;
        binary(lane, model.rows[rctx], zero ? 1u : 0u);
        return zero;
    }
    /// One row's pass: per x the pending symbol event, straight into its place in the group's events (see
    /// SymbolSlots), the symbol, magnitude and sign class (j.syms, j.mag, j.sgn: the walker's context); per
    /// non-zero coefficient its sign context | negative << 16 (signs); per coefficient with raw mantissa
    /// bits (symbol >= 4) those bits with a 1 above them (raws, `rawCount` of them). Returns the non-zero
    /// count; `all` collects the magnitudes' bits. The encoder knows
    /// the previous symbol, so nothing chains from one x to the next. The reference for encodeRowSimd.
    static std::size_t encodeRow(const RowJob& j, const SymbolSlots& slots, std::uint32_t* signs,
                                 std::uint32_t* raws, std::size_t& rawCount, std::uint32_t& all) {
        const std::int32_t* row = j.row;
        const std::uint32_t* activity = j.activity;
        const std::uint16_t* signBase = j.signBase;
        std::uint32_t* mag = j.mag;
        std::uint8_t* sgn = j.sgn;
        std::uint8_t* syms = j.syms;
        unsigned prevSym = 0, prevSign = 0;
        std::size_t count = 0, rawN = 0;
        std::uint32_t any = 0;
        for (std::size_t x = 0; x < j.nx; ++x) {
            const std::int32_t v = row[x];
            const std::uint32_t u = magnitude(v);
            any |= u;
            const auto sym = static_cast<unsigned>(symbolOf(u));
            const auto ctx = static_cast<unsigned>(activityContext(activity[x] + kSymbolInfo.west[prevSym]));
            prevSym = sym;
            slots.events[x < slots.minNx ? x * slots.rows + slots.row : slots.tail + x] =
                pendingEvent(ctx * 64 + sym, j.lane);
            syms[x] = static_cast<std::uint8_t>(sym);
            mag[x] = u;
            const unsigned sign = signClass(v);
            sgn[x] = static_cast<std::uint8_t>(sign);
            signs[count] = (signBase[x] + prevSign) | static_cast<std::uint32_t>(v < 0) << 16;
            prevSign = sign;
            // Symbols above 59 (magnitudes out of range) are refused before anything uses these.
            const unsigned rawBits = kSymbolInfo.rawBits[sym & 63]; // 0 for symbols below 4
            raws[rawN] = (u & ((1u << rawBits) - 1u)) | 1u << rawBits;
            rawN += rawBits != 0;
            count += v != 0;
        }
        all |= any;
        rawCount = rawN;
        return count;
    }
    void rows(RowJob* jobs, std::size_t nj) {
        // Per row: the row pass (encodeRow or its SIMD twin) and the symbol counts; then the symbol events in
        // the decoder's interleaved order.
        std::size_t maxNx = 0;
        for (std::size_t i = 0; i < nj; ++i)
            maxNx = std::max(maxNx, jobs[i].nx);
        // Per row of the group, from the row pass: per non-zero coefficient the sign context with the
        // negative bit at 16, per coefficient with raw bits those bits with a 1 above them.
        std::uint32_t* const signCodes = EncoderScratch::atLeast(scratch.signCodes, nj * maxNx);
        std::uint32_t* const rawCodes = EncoderScratch::atLeast(scratch.rawCodes, nj * maxNx);
        std::size_t minNx = maxNx;
        for (std::size_t i = 0; i < nj; ++i)
            minNx = std::min(minNx, jobs[i].nx);
        std::uint32_t all = 0;
        std::size_t tail = minNx * nj; // where the part of the row past minNx goes
        std::size_t rawCount[kMaxLanes];
        for (std::size_t i = 0; i < nj; ++i) {
            RowJob& j = jobs[i];
            const SymbolSlots slots{next, nj, i, minNx, tail - minNx};
            tail += j.nx - minNx;
            if (simd)
                j.count =
                    simd->encodeRow(j, slots, signCodes + i * maxNx, rawCodes + i * maxNx, rawCount[i], all);
            else
                j.count = encodeRow(j, slots, signCodes + i * maxNx, rawCodes + i * maxNx, rawCount[i], all);
        }
        // Before the counts are indexed with the symbols.
        if (all >> kMaxBitLength) throw Error("internal: wavelet coefficient magnitude out of range");
        // Two histograms taken in turn: runs of one code (mostly zeros) would otherwise chain every
        // increment to the previous one through memory.
        std::size_t k = 0;
        for (; k + 1 < tail; k += 2) {
            ++counts[0][next[k] & kEventFieldMask];
            ++counts[1][next[k + 1] & kEventFieldMask];
        }
        if (k < tail) ++counts[0][next[k] & kEventFieldMask];
        next += tail;
        // Sign events straight in the decoder's interleaved order (the n-th non-zero coefficient of each row
        // in turn), without jumps: steps past a row's count code a dummy model and leave no event (the
        // store lands where the next event goes). Rows of a group use disjoint sign models, so their model
        // chains are independent and overlap.
        std::size_t maxCount = 0;
        std::size_t rowCount[kMaxLanes];
        unsigned rowLane[kMaxLanes];
        for (std::size_t i = 0; i < nj; ++i) {
            rowCount[i] = jobs[i].count;
            rowLane[i] = jobs[i].lane;
            maxCount = std::max(maxCount, jobs[i].count);
        }
        BitModel dummy;
        RansEvent* ev = next;
        if (simd)
            ev = simd->signEvents(rowCount, rowLane, nj, maxCount, signCodes, maxNx, model.signs.data(), ev);
        else
            for (std::size_t n = 0; n < maxCount; ++n)
                for (std::size_t i = 0; i < nj; ++i) {
                    const bool valid = n < rowCount[i];
                    const std::uint32_t sc = signCodes[i * maxNx + n];
                    BitModel& m = valid ? model.signs[sc & 0xFFFF] : dummy;
                    *ev = binaryEvent(m, sc >> 16, rowLane[i]);
                    ev += valid;
                }
        next = ev;
        for (std::size_t i = 0; i < nj; ++i)
            raw.put(rawCodes + i * maxNx, rawCount[i]);
    }
};

} // namespace

void encodeDense(std::span<const std::int32_t> coeffs, Dims brick,
                 const std::vector<std::vector<SubbandBox>>& layout, std::size_t s,
                 std::vector<std::uint8_t>& out) {
    bool anyNonZero = false;
    for (const SubbandBox& b : layout[s])
        for (std::size_t z = b.z0; z < b.z1 && !anyNonZero; ++z)
            for (std::size_t y = b.y0; y < b.y1 && !anyNonZero; ++y) {
                const std::int32_t* row = coeffs.data() + (z * brick.y + y) * brick.x;
                anyNonZero = std::any_of(row + b.x0, row + b.x1, [](std::int32_t v) { return v != 0; });
            }
    if (!anyNonZero) {
        out.push_back(kAllZero);
        return;
    }
    EncodeSide side;
    side.simd = denseEncoderKernels();
    std::size_t maxEvents = 0;
    for (const SubbandBox& b : layout[s])
        maxEvents += 2 * b.count() + (b.y1 - b.y0) * (b.z1 - b.z0);
    // 8 events more: the SIMD pass loads 8 events from a group's start.
    RansEvent* const firstEvent = EncoderScratch::atLeast(side.scratch.events, maxEvents + 8);
    side.next = firstEvent;
    SectionWalker walker{brick, layout, s};
    // The encoder side only reads the coefficient array.
    walker.run(const_cast<std::int32_t*>(coeffs.data()), side);
    const std::span<const std::uint8_t> rawBytes = side.raw.finish();

    // Cost estimate of both context modes from the counts (entropy plus table bits); keep the cheaper one.
    auto cost = [](const std::array<std::uint32_t, kSymbols>& cnt) {
        std::uint64_t total = 0;
        int nsym = 0;
        for (int i = 0; i < kSymbols; ++i)
            if (cnt[static_cast<std::size_t>(i)]) {
                total += cnt[static_cast<std::size_t>(i)];
                nsym = i + 1;
            }
        double bits = 6.0 + kTableBitsPerEntry * nsym;
        for (auto v : cnt)
            if (v) bits -= double(v) * std::log2(double(v) / double(total));
        return bits;
    };
    std::array<std::array<std::uint32_t, kSymbols>, kActivityContexts> contextCounts{};
    for (std::size_t c = 0; c < kActivityContexts; ++c)
        for (std::size_t i = 0; i < kSymbols; ++i)
            contextCounts[c][i] = side.counts[0][c * 64 + i] + side.counts[1][c * 64 + i];
    std::array<std::uint32_t, kSymbols> merged{};
    double split = 0;
    for (const auto& cnt : contextCounts) {
        split += cost(cnt);
        for (std::size_t i = 0; i < kSymbols; ++i)
            merged[i] += cnt[i];
    }
    const bool useContexts = split < cost(merged) + 6.0 * (kActivityContexts - 1);

    std::array<std::array<std::uint32_t, kSymbols>, kActivityContexts> counts{};
    if (useContexts)
        counts = contextCounts;
    else
        counts[0] = merged;
    std::array<SymbolTable, kActivityContexts> tables{};
    BitWriter tableBits;
    const int ntables = useContexts ? kActivityContexts : 1;
    for (int t = 0; t < ntables; ++t) {
        const auto& cnt = counts[static_cast<std::size_t>(t)];
        std::uint64_t total = 0;
        int nsym = 0;
        for (int i = 0; i < kSymbols; ++i)
            if (cnt[static_cast<std::size_t>(i)]) {
                total += cnt[static_cast<std::size_t>(i)];
                nsym = i + 1;
            }
        tableBits.put(static_cast<std::uint32_t>(nsym), 6);
        if (nsym == 0) continue;
        std::array<std::uint8_t, kSymbols> q{};
        for (int i = 0; i < nsym; ++i) {
            q[static_cast<std::size_t>(i)] = quantiseCount(cnt[static_cast<std::size_t>(i)], total);
            tableBits.put(q[static_cast<std::size_t>(i)], 6);
        }
        buildTable(q, nsym, tables[static_cast<std::size_t>(t)]);
    }
    tableBits.finish();

    // Slots of every pending code (context * 64 + symbol) in one flat table: the backward pass then resolves
    // an event with one load, no test of the mode and no division.
    std::array<RansEvent, kActivityContexts * 64> codeSlots{};
    for (std::size_t c = 0; c < kActivityContexts; ++c)
        for (std::size_t sym = 0; sym < kSymbols; ++sym) {
            const SymbolTable& t = tables[useContexts ? c : 0];
            codeSlots[c * 64 + sym] = ransEvent(t.start[sym], t.freq[sym], false, 0);
        }
    std::vector<std::uint8_t> stream;
    std::fill(side.next, side.next + 8, RansEvent(0)); // defined values in the SIMD pass's last loads
    const std::span<RansEvent> events(firstEvent, side.next);
    const int lanes = static_cast<int>(layout[s].size());
    if (side.simd)
        side.simd->ransEncode(events, lanes, codeSlots.data(), stream);
    else
        ransEncode(events, lanes, codeSlots.data(), stream);

    out.push_back(useContexts ? kContextTables : kOneTable);
    out.insert(out.end(), tableBits.bytes.begin(), tableBits.bytes.end());
    putVarint(out, stream.size());
    out.insert(out.end(), stream.begin(), stream.end());
    out.insert(out.end(), rawBytes.begin(), rawBytes.end());
}

} // namespace volcl::entropy
