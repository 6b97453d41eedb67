// Where the benchmarks' tables go (a file given by --csv/--json, written atomically, else stdout) and the
// load they were measured under.
#pragma once

#include <string>

namespace volcl::cli {

/// Writes `text` to `path` through an AtomicFile, or to stdout when `path` is empty.
void writeOutput(const std::string& path, const std::string& text);

/// The 1, 5 and 15 minute load averages ("2.10, 1.95, 1.80"), stated beside every timing.
std::string loadAverage();

} // namespace volcl::cli
