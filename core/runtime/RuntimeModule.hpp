// Optional parts of libvolcl built as modules (OpenImageIO, OpenVDB), loaded when first used, and the helper
// programs installed beside them.
#pragma once

#include <filesystem>

namespace volcl {

/// Loads the module `file` from libvolcl's own directory, else from the library search path, keeps it
/// loaded for the life of the process (the libraries behind it hold global state) and returns what its
/// exported function `entry` (declared `extern "C" const void* entry()`) returns: the module's table of
/// functions. Throws IoError naming the file and `purpose` when it does not load or lacks the entry.
const void* loadRuntimeModule(const char* file, const char* entry, const char* purpose);

/// Path of the helper executable `file` in libvolcl's own directory (where the build and every install
/// layout put it). Throws IoError naming the file and `purpose` when it is missing or not executable.
std::filesystem::path findRuntimeHelper(const char* file, const char* purpose);

} // namespace volcl
