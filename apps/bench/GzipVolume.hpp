// Reading a gzipped headerless volume of known dims (the BrainWeb T1 of the codec, motion and series benchmarks).
#pragma once

#include "core/Volume.hpp"

#include <filesystem>

namespace volcl::cli {

/// The uint8 voxels of a gzipped raw file of `dims`; IoError naming the file when it cannot be opened or
/// inflates to another size (shorter or longer).
Volume readGzipUInt8(const std::filesystem::path& path, Dims dims);

} // namespace volcl::cli
