// .vcz files in the CLI: `volcl info`'s header and frame table, and the NIfTI header decode/convert write.
#pragma once

#include "host/io/VolumeIo.hpp"
#include "wavelet/Codec.hpp"

#include <ostream>
#include <string>

namespace volcl::cli {

/// Prints the .vcz file's grid (dims, type, spacing, origin), codec settings and one line per frame, and
/// with `listBricks` one line per brick and frame (JSON with `json`: always every brick). Parses the
/// header and index (validated) from a mapping of the file and checks every payload's checksum, handing
/// its pages back after it: memory holds the header and index, not the file. No frame is decoded.
void printVczInfo(std::ostream& out, const std::string& path, bool json, bool listBricks = false);

/// Write options for a volume decoded from `header`: the NIfTI source's header it keeps (for NIfTI
/// outputs) and whether its voxels are that source's stored integers (data units for other outputs).
/// Throws IoError naming `name` for malformed metadata.
WriteOptions vczWriteOptions(const VczHeader& header, const std::string& name);

} // namespace volcl::cli
