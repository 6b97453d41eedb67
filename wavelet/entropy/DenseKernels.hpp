// The dense coder's vector kernels as function tables, chosen once at start from what the CPU has: the
// scalar code in DenseEncoder.cpp / DenseDecoder.cpp is always built and is the reference; a table is null
// where the CPU (or the build target) has no vector version, and the test switches turn a table off.
#pragma once

#include "wavelet/entropy/DenseModel.hpp"

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace volcl::entropy {

/// The decoder's vector passes over a row group (see DenseDecoder.cpp for the scalar order they keep).
struct DenseDecoderKernels {
    /// Magnitude symbols of columns [0, steps) of the group; `lastMask`: the rows active in the last column.
    void (*symbols)(const RowJob* jobs, std::size_t nj, std::size_t steps, unsigned lastMask, WordReader& in,
                    std::uint32_t* st, const PackedTables& pt);
    /// A row's lists of non-zero coefficients and of those with raw bits; base magnitudes, cleared signs.
    void (*listNonZero)(RowJob& j);
    /// Signs of the group's non-zero coefficients, `steps` of them at most per row.
    void (*signs)(const RowJob* jobs, std::size_t nj, std::size_t steps, const std::uint32_t* counts,
                  WordReader& in, std::uint32_t* st, BitModel* models);
};

/// The encoder's vector passes (same outputs as the scalar EncodeSide::encodeRow and loops).
struct DenseEncoderKernels {
    bool (*rowIsZero)(const std::int32_t* row, std::size_t nx);
    std::size_t (*encodeRow)(const RowJob& j, const SymbolSlots& slots, std::uint32_t* signs,
                             std::uint32_t* raws, std::size_t& rawCount, std::uint32_t& all);
    RansEvent* (*signEvents)(const std::size_t* rowCount, const unsigned* rowLane, std::size_t nj,
                             std::size_t steps, const std::uint32_t* signCodes, std::size_t pitch,
                             BitModel* models, RansEvent* ev);
    /// The backward rANS pass of ransEncode; `events` are resolved in place, 8 readable events follow them.
    void (*ransEncode)(std::span<RansEvent> events, int lanes, const RansEvent* codeSlots,
                       std::vector<std::uint8_t>& out);
    /// Whether the kernels' arithmetic stand-ins for the model's tables agree with them on every class of
    /// input (a test hook).
    bool (*arithmeticMatchesTables)();
};

/// The kernels in use: null for the scalar path (no vector version, or forced by a test switch).
const DenseDecoderKernels* denseDecoderKernels() noexcept;
const DenseEncoderKernels* denseEncoderKernels() noexcept;

/// The AVX-512 tables (DenseDecoderAvx512.cpp, DenseEncoderAvx512.cpp), null where the CPU lacks the
/// instruction sets. Built on x86-64 only.
const DenseDecoderKernels* avx512DenseDecoderKernels() noexcept;
const DenseEncoderKernels* avx512DenseEncoderKernels() noexcept;

} // namespace volcl::entropy
