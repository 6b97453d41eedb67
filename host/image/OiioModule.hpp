// The OpenImageIO half of image I/O: a module that libvolcl loads when an image is first read or written.
#pragma once

#include "host/image/ImageIo.hpp"

#include <cstdint>
#include <filesystem>

namespace volcl {

/// The formats writeImage accepts (chosen from the target's extension).
enum class ImageFileFormat : std::uint8_t { Exr, Png };

/// Entry points of the module. Debian's OpenImageIO pulls in ~260 shared libraries whose symbol binding cost
/// every `volcl` start 0.3 s; loaded on demand, only commands that touch images pay it. The functions
/// throw volcl's exceptions (the module links libvolcl, so both sides share their type information).
struct OiioModule {
    /// Writes a validated image (writeImage checked sizes, format and half range) atomically.
    void (*write)(const ImageBuffer& image, const std::filesystem::path& path, ImageFileFormat format,
                  const ImageWriteOptions& options);
    /// Reads an existing file as float pixels with its attributes.
    /// Reads an image; one whose pixels (as float) exceed `memoryBudget` bytes (0 = the default budget) is
    /// refused before they are allocated.
    ImageBuffer (*read)(const std::filesystem::path& path, std::size_t memoryBudget);
};

/// File name of the module; it is looked up beside libvolcl, then on the library search path.
inline constexpr const char* kOiioModuleFile = "libvolcl_oiio.so";
/// Name of the module's one exported function, which returns its OiioModule.
inline constexpr const char* kOiioModuleEntry = "volcl_oiio_module";

} // namespace volcl
