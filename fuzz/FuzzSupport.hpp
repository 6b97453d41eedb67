// Helpers shared by the fuzz targets: a private scratch directory and writing an input into it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string_view>

namespace volcl::fuzz {

/// A directory private to this process (created on first use, removed at exit) for inputs that the code
/// under test reads from a path. It lies in /dev/shm where that exists: on a RAM file system writing and
/// reading an input costs no disk I/O, which was a large share of a reader target's time per input.
const std::filesystem::path& scratchDirectory();

/// Writes `bytes` to scratchDirectory() / name, replacing what was there, and returns the path.
std::filesystem::path writeScratchFile(std::string_view name, std::span<const std::uint8_t> bytes);

/// Memory budget of every fuzz target (ReadOptions::memoryBudget and the .vcz pre-check): inputs may
/// claim up to 64 MiB, enough for every seed, small enough that a forged size cannot exhaust the machine.
/// Under AddressSanitizer the process keeps what an input freed (up to 256 MB of quarantine, and the
/// allocator's free lists at their high-water mark), so inputs that each stayed within a 256 MiB budget
/// pushed long runs past libFuzzer's 500 MB RSS limit after millions of executions (fuzz_series_pvd,
/// fuzz_vcz_bricks) although no single one came near it.
inline constexpr std::size_t kFuzzMemoryBudget = std::size_t{64} << 20;

} // namespace volcl::fuzz
