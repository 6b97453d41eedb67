// Parsing helpers shared by subcommands: dims triples, boxes, raw-read options.
#pragma once

#include "host/io/VolumeIo.hpp"

#include <CLI/CLI.hpp>

#include <string>

namespace volcl::cli {

/// Shows `examples` (indented command lines) at the foot of the subcommand's --help.
void setExamples(CLI::App& app, const std::string& examples);

/// "X,Y,Z" or "XxYxZ" -> Dims; throws UsageError naming `what`.
Dims parseDims(const std::string& text, const std::string& what);
/// "x0,y0,z0:x1,y1,z1" (half-open voxel box) -> (lo, hi); throws UsageError.
std::pair<Dims, Dims> parseBox(const std::string& text, const std::string& what);

/// Single-quotes `s` for /bin/sh (peer benchmarks run Python scripts through std::system).
std::string shellQuote(const std::string& s);

/// Input flags shared by commands: raw layout (--dims, --type, --endian, --header-bytes) --grid (VDB) and --series (DICOM).
struct RawReadFlags {
    std::string dims, type, endian = "little";
    std::string vdbGrid;     ///< --grid: OpenVDB grid name
    std::string dicomSeries; ///< --series: DICOM Series Instance UID
    std::size_t headerBytes = 0;
    bool allowExternalData = false; ///< --allow-external-data: header data files outside its directory
    int channel = -1;               ///< --channel K: one channel of a multi-channel file (-1: not given)
    void add(CLI::App& cmd);
    ReadOptions toReadOptions() const;
};

} // namespace volcl::cli
