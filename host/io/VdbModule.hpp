// The OpenVDB half of .vdb I/O: a module that libvolcl loads when a .vdb file is first read or written.
#pragma once

#include "host/io/VolumeIo.hpp"

#include <filesystem>

namespace volcl::io {

/// Entry points of the module. libopenvdb needs about 52,000 symbol bindings when it is loaded, which cost
/// every `volcl` process ~50 ms at start; loaded on demand, only commands that touch .vdb files pay it. The
/// functions throw volcl's exceptions (the module links libvolcl, so both sides share their type
/// information).
struct VdbModule {
    /// Reads the file's scalar grid densified over its box (the caller has checked the file's layout).
    TimeSeries (*read)(const std::filesystem::path& path, const ReadOptions& options);
    /// Writes the volume as an exact FloatGrid, atomically.
    void (*write)(const Volume& volume, const std::filesystem::path& path, const WriteOptions& options);
};

/// File name of the module; it is looked up beside libvolcl, then on the library search path.
inline constexpr const char* kVdbModuleFile = "libvolcl_vdb.so";
/// Name of the module's one exported function, which returns its VdbModule.
inline constexpr const char* kVdbModuleEntry = "volcl_vdb_module";

} // namespace volcl::io
