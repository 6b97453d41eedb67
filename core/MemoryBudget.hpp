// The memory budget: the largest amount of memory one input file may make volcl allocate.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string_view>

namespace volcl {

/// Default budget: half of the machine's physical memory, at least 1 GiB. A size claim above the
/// budget (a header promising 10^11 voxels, a forged .vcz) is refused before anything is allocated,
/// so a lying file ends in a one-line error naming it instead of an allocation failure. Readers take
/// the budget from ReadOptions::memoryBudget (0 = this default); raise it there to read larger inputs.
std::size_t defaultMemoryBudget() noexcept;

/// `volcl encode` streams an input (reads and codes it one brick row at a time) when its decoded voxels
/// exceed this many bytes and it can be streamed (lossless, integer, a raw/NRRD/NIfTI file): above it the
/// whole-volume encoder's copies (input, transform buffers) would be the process's largest allocations.
inline constexpr std::size_t kStreamEncodeAboveBytes = std::size_t(256) << 20;

/// `budget` itself, or the default when it is 0.
std::size_t effectiveMemoryBudget(std::size_t budget) noexcept;

/// Throws IoError "<file>: <what> needs N bytes, more than the memory budget of M bytes" when `bytes`
/// exceeds the budget (0 = the default).
void checkMemoryBudget(std::size_t bytes, std::size_t budget, const std::filesystem::path& file,
                       std::string_view what);

/// In a reader process of its own (a forked or spawned reader of a library that trusts sizes inside
/// its files): caps the address space at what is mapped now (the program, its libraries, and a
/// sanitizer's shadow where there is one) plus twice `budget` bytes, so a forged size makes the
/// allocation fail instead of touching gigabytes. Leaves the limit alone when it cannot be read or
/// is already lower.
void capAddressSpace(unsigned long long budget) noexcept;

} // namespace volcl
