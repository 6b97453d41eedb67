// Where the benchmarks' tables go (a file given by --csv/--json, written atomically, else stdout) and the load
// average stated beside them.
#pragma once

#include <string>

namespace volcl::cli {

/// Writes `text` to `path` through an AtomicFile, or to stdout when `path` is empty.
void writeOutput(const std::string& path, const std::string& text);

/// The 1, 5 and 15 minute load averages as `uptime` prints them ("1.02, 0.87, 0.55"), every benchmark's
/// statement of the machine's load; "unknown" when the system does not say.
std::string loadAverage();

} // namespace volcl::cli
