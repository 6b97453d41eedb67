// Peak resident memory of this process, for reports of how much memory a run really used.
#pragma once

#include <cstddef>

namespace volcl {

/// Largest resident set size this process has had so far, in bytes (getrusage's ru_maxrss).
std::size_t peakResidentBytes() noexcept;

} // namespace volcl
