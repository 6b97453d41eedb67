// Kernel source lookup: files embedded at build time from cl/, or read from $VOLCL_KERNEL_DIR when set.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace volcl {

namespace detail {
struct EmbeddedKernelFile {
    const char* name;
    const char* source;
};
extern const EmbeddedKernelFile kEmbeddedKernelFiles[];
extern const std::size_t kEmbeddedKernelFileCount;
} // namespace detail

/// Resolves a kernel file to self-contained source: `#include "x.h"` lines naming other cl/ files are
/// expanded in place (each file once), so the program text and its hash cover everything it uses. Files
/// are named by their path relative to cl/ ("render/raymarch.cl", "common/shading.h"); an include is looked up
/// beside the including file first, then relative to cl/.
class KernelSourceLibrary {
public:
    /// `overrideDir`: read files from this directory instead of the embedded copies (development).
    explicit KernelSourceLibrary(std::optional<std::filesystem::path> overrideDir = std::nullopt);
    /// Library configured from the environment ($VOLCL_KERNEL_DIR).
    static KernelSourceLibrary fromEnvironment();

    /// Expanded source of `file` (e.g. "phantoms/phantoms.cl"). Throws Error when a file is missing.
    std::string resolve(std::string_view file) const;
    const std::optional<std::filesystem::path>& overrideDir() const noexcept { return overrideDir_; }
    /// True when `file` (a path relative to cl/) exists in the embedded set or the override directory.
    bool has(std::string_view file) const;

private:
    std::string raw(std::string_view file) const;
    std::optional<std::filesystem::path> overrideDir_;
};

/// 64-bit FNV-1a hash, used for program cache keys.
std::uint64_t fnv1a64(std::string_view text, std::uint64_t seed = 0xcbf29ce484222325ull) noexcept;

} // namespace volcl
