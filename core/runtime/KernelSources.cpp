// Kernel source lookup (embedded or from $VOLCL_KERNEL_DIR) with in-place expansion of local includes.
#include "core/runtime/KernelSources.hpp"

#include "core/Error.hpp"

#include <cstdlib>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>

namespace volcl {

std::uint64_t fnv1a64(std::string_view text, std::uint64_t seed) noexcept {
    std::uint64_t h = seed;
    for (unsigned char c : text) {
        h ^= c;
        h *= 0x100000001b3ull;
    }
    return h;
}

KernelSourceLibrary::KernelSourceLibrary(std::optional<std::filesystem::path> overrideDir)
    : overrideDir_(std::move(overrideDir)) {}

KernelSourceLibrary KernelSourceLibrary::fromEnvironment() {
    const char* dir = std::getenv("VOLCL_KERNEL_DIR");
    if (dir && *dir) return KernelSourceLibrary(std::filesystem::path(dir));
    return KernelSourceLibrary();
}

std::string KernelSourceLibrary::raw(std::string_view file) const {
    if (overrideDir_) {
        std::filesystem::path p = *overrideDir_ / std::string(file);
        std::ifstream in(p, std::ios::binary);
        if (!in) throw Error("kernel file " + p.string() + " not found (VOLCL_KERNEL_DIR is set)");
        std::ostringstream ss;
        ss << in.rdbuf();
        return ss.str();
    }
    for (std::size_t i = 0; i < detail::kEmbeddedKernelFileCount; ++i)
        if (file == detail::kEmbeddedKernelFiles[i].name) return detail::kEmbeddedKernelFiles[i].source;
    throw Error("kernel file " + std::string(file) + " is not embedded (missing from cl/kernels.cmake?)");
}

bool KernelSourceLibrary::has(std::string_view file) const {
    if (overrideDir_) return std::filesystem::is_regular_file(*overrideDir_ / std::string(file));
    for (std::size_t i = 0; i < detail::kEmbeddedKernelFileCount; ++i)
        if (file == detail::kEmbeddedKernelFiles[i].name) return true;
    return false;
}

namespace {
// The library name of `#include "name"` in file `includer`: beside the includer when such a file exists
// (as a C compiler looks first), else relative to cl/ itself. Names are normalised ("common/../x.h" is
// "x.h"), so a file reached by two spellings is still included once.
std::string includeName(const KernelSourceLibrary& lib, std::string_view includer, std::string_view name) {
    namespace fs = std::filesystem;
    const fs::path folder = fs::path(std::string(includer)).parent_path();
    const std::string beside = (folder / std::string(name)).lexically_normal().generic_string();
    if (!folder.empty() && lib.has(beside)) return beside;
    return fs::path(std::string(name)).lexically_normal().generic_string();
}

// Expands `#include "name"` lines; each file is included once, like a header guard would do.
void expand(const KernelSourceLibrary& lib, std::string_view file,
            const std::function<std::string(std::string_view)>& raw, std::set<std::string>& seen,
            std::string& out) {
    if (!seen.insert(std::string(file)).second) return;
    std::istringstream in(raw(file));
    std::string line;
    int lineNo = 0;
    out += "#line 1 \"" + std::string(file) + "\"\n";
    while (std::getline(in, line)) {
        ++lineNo;
        std::size_t p = line.find_first_not_of(" \t");
        if (p != std::string::npos && line.compare(p, 8, "#include") == 0) {
            std::size_t q1 = line.find('"', p), q2 = q1 == std::string::npos ? q1 : line.find('"', q1 + 1);
            if (q2 != std::string::npos) {
                expand(lib, includeName(lib, file, std::string_view(line).substr(q1 + 1, q2 - q1 - 1)), raw,
                       seen, out);
                out += "#line " + std::to_string(lineNo + 1) + " \"" + std::string(file) + "\"\n";
                continue;
            }
        }
        out += line;
        out += '\n';
    }
}
} // namespace

std::string KernelSourceLibrary::resolve(std::string_view file) const {
    std::set<std::string> seen;
    std::string out;
    expand(
        *this, file, [this](std::string_view f) { return raw(f); }, seen, out);
    return out;
}

} // namespace volcl
