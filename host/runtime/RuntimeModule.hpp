// Optional parts of libvolcl built as modules (OpenImageIO, OpenVDB), loaded when first used.
#pragma once

namespace volcl {

/// Loads the module `file` from libvolcl's own directory, else from the library search path, keeps it
/// loaded for the life of the process (the libraries behind it hold global state) and returns what its
/// exported function `entry` returns: the module's table of functions. Throws IoError naming the file and
/// `purpose` when it does not load or lacks the entry.
const void* loadRuntimeModule(const char* file, const char* entry, const char* purpose);

} // namespace volcl
