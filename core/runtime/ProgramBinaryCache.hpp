// On-disk cache of OpenCL program binaries, keyed on device, driver, build options and expanded source.
#pragma once

#include "core/runtime/ClRuntime.hpp"

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace volcl {

/// One entry of the program binary cache. ComputeContext::program consults it before building from source:
/// PoCL runs clang's preprocessor over the whole source on every source build (to find its own kernel
/// cache), which dominated short runs of the CLI. The directory is $VOLCL_CACHE_DIR, else
/// $XDG_CACHE_HOME/volcl, else $HOME/.cache/volcl (`VOLCL_CACHE_DIR=off` disables the cache). Entries hold
/// the full key and a checksum of the binary; anything that does not match exactly is ignored and replaced.
/// Example:
/// ```
/// volcl::ProgramBinaryCache entry(cc.device(), "-DLEVELS=4", source);
/// if (auto binary = entry.load()) { /* clCreateProgramWithBinary ... */ }
/// else { /* build from source */ entry.store(program); }
/// ```
class ProgramBinaryCache {
public:
    ProgramBinaryCache(const DeviceInfo& device, std::string_view options, std::string_view source);

    /// The cache directory from the environment, or nullopt when disabled or no home is known.
    static std::optional<std::filesystem::path> directory();
    /// This entry's file, or nullopt when the cache is disabled.
    const std::optional<std::filesystem::path>& file() const noexcept { return file_; }

    /// The stored binary, when an intact entry with exactly this key exists. Never throws.
    std::optional<std::vector<unsigned char>> load() const noexcept;
    /// Stores the program's binary for the device atomically. Failures (read-only or full disk, a driver
    /// without binaries) are ignored: the cache only saves time. Never throws.
    void store(const cl::Program& program) const noexcept;

private:
    std::string identity_; ///< platform, device, versions and build options
    std::uint64_t sourceHash_ = 0, sourceCheck_ = 0, sourceSize_ = 0;
    cl::Device device_;
    std::optional<std::filesystem::path> file_;
};

} // namespace volcl
