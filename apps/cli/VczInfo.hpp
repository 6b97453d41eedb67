// `volcl info` of a .vcz file: the header and the frame table (type, references, bytes, bits/voxel).
#pragma once

#include <ostream>
#include <string>

namespace volcl::cli {

/// Prints the .vcz file's grid, codec settings and one line per frame (JSON with `json`). Reads only
/// the header and index (validated); no frame is decoded.
void printVczInfo(std::ostream& out, const std::string& path, bool json);

} // namespace volcl::cli
