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
/// claim up to 256 MiB, enough for every seed, small enough that a forged size cannot exhaust the machine.
inline constexpr std::size_t kFuzzMemoryBudget = std::size_t{256} << 20;

} // namespace volcl::fuzz
