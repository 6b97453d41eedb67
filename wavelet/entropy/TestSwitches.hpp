// Test and measurement switches of the entropy coders (internal: not part of the codec's public API).
#pragma once

namespace volcl {

/// Which dense decoder runs: the AVX-512 one (VBMI2 and friends, chosen at run time when the CPU has them)
/// or the portable scalar one. Both decode every stream identically (tests run both); forcing the scalar
/// path is for tests and measurements. The environment variable VOLCL_DENSE_SCALAR=1 forces it at start.
bool denseDecoderSimdAvailable() noexcept;
void setDenseDecoderScalar(bool force) noexcept;
bool denseDecoderIsScalar() noexcept;
/// Likewise for the dense encoder (AVX-512 where the CPU has it, else scalar), a switch of its own: both
/// write the same bytes (tests compare them). VOLCL_DENSE_SCALAR=1 forces the scalar encoder too.
void setDenseEncoderScalar(bool force) noexcept;
bool denseEncoderIsScalar() noexcept;
/// Whether dense-mode sections may be coded by set partitioning where it is smaller (default: yes). Off,
/// every payload is what the dense coder alone writes: tests compare the two files' voxels (the same
/// integers are coded) and measurements the two coders' sizes and speeds.
void setSetPartitioningEnabled(bool on) noexcept;
bool setPartitioningEnabled() noexcept;
/// For tests: whether the SIMD encoder's arithmetic stand-ins for the scalar coder's tables (magnitude
/// symbol, the previous symbol's W, activity class) agree with the tables on every class of input; true
/// where the CPU has no SIMD encoder.
bool denseEncoderArithmeticMatchesTables();

} // namespace volcl
