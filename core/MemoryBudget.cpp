// The memory budget: default from the physical memory size, and the check every size claim passes.
#include "core/MemoryBudget.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <string>

#include <unistd.h>

namespace volcl {

std::size_t defaultMemoryBudget() noexcept {
    constexpr std::size_t kMinimum = std::size_t{1} << 30;
    const long pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGESIZE);
    if (pages <= 0 || pageSize <= 0) return kMinimum;
    const std::size_t physical = static_cast<std::size_t>(pages) * static_cast<std::size_t>(pageSize);
    return std::max(kMinimum, physical / 2);
}

std::size_t effectiveMemoryBudget(std::size_t budget) noexcept {
    return budget != 0 ? budget : defaultMemoryBudget();
}

void checkMemoryBudget(std::size_t bytes, std::size_t budget, const std::filesystem::path& file,
                       std::string_view what) {
    const std::size_t limit = effectiveMemoryBudget(budget);
    if (bytes > limit)
        throw IoError(file.string() + ": " + std::string(what) + " needs " + std::to_string(bytes) +
                      " bytes, more than the memory budget of " + std::to_string(limit) +
                      " bytes (corrupt or lying header?)");
}

} // namespace volcl
