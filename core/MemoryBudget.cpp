// The memory budget: default from the physical memory size, and the check every size claim passes.
#include "core/MemoryBudget.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cstdio>
#include <string>

#include <sys/resource.h>
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

// Sizes inside a file are the reading library's to trust (libopenvdb's grid data, GDCM's element lengths):
// a forged one made libopenvdb allocate and touch 5 GB from an 11 KB file; past the cap the allocation
// fails and the read ends as a corrupt file.
void capAddressSpace(unsigned long long budget) noexcept {
    std::FILE* statm = std::fopen("/proc/self/statm", "r");
    unsigned long long pages = 0;
    const bool known = statm && std::fscanf(statm, "%llu", &pages) == 1;
    if (statm) std::fclose(statm);
    rlimit limit{};
    if (!known || ::getrlimit(RLIMIT_AS, &limit) != 0) return;
    const unsigned long long cap =
        pages * static_cast<unsigned long long>(::sysconf(_SC_PAGESIZE)) + 2ull * budget;
    if (limit.rlim_max != RLIM_INFINITY && cap > limit.rlim_max) return;
    if (limit.rlim_cur != RLIM_INFINITY && cap > limit.rlim_cur) return;
    limit.rlim_cur = static_cast<rlim_t>(cap);
    (void)::setrlimit(RLIMIT_AS, &limit);
}

} // namespace volcl
