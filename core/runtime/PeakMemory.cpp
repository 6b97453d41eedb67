// Peak resident memory from getrusage (Linux reports ru_maxrss in KiB).
#include "core/runtime/PeakMemory.hpp"

#include <sys/resource.h>

namespace volcl {

std::size_t peakResidentBytes() noexcept {
    rusage u{};
    if (getrusage(RUSAGE_SELF, &u) != 0) return 0;
    return std::size_t(u.ru_maxrss) * 1024;
}

} // namespace volcl
