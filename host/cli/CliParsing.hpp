// Parsing helpers shared by subcommands: dims triples, boxes, raw-read options.
#pragma once

#include "host/io/VolumeIo.hpp"

#include <CLI/CLI.hpp>

#include <string>

namespace volcl::cli {

/// "X,Y,Z" or "XxYxZ" -> Dims; throws UsageError naming `what`.
Dims parseDims(const std::string& text, const std::string& what);
/// "x0,y0,z0:x1,y1,z1" (half-open voxel box) -> (lo, hi); throws UsageError.
std::pair<Dims, Dims> parseBox(const std::string& text, const std::string& what);

/// Flags describing headerless raw input (--dims, --type, --endian, --header-bytes), shared by commands.
struct RawReadFlags {
    std::string dims, type, endian = "little";
    std::size_t headerBytes = 0;
    void add(CLI::App& cmd);
    ReadOptions toReadOptions() const;
};

} // namespace volcl::cli
