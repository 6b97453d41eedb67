// Where the benchmarks' tables go: a file given by --csv/--json (written atomically), else stdout; the load
// average every figure is reported with.
#pragma once

#include <string>

namespace volcl::cli {

/// Writes `text` to `path` through an AtomicFile, or to stdout when `path` is empty.
void writeOutput(const std::string& path, const std::string& text);

/// The 1, 5 and 15 minute load averages as "l1, l5, l15" (two decimals), or "unknown".
std::string loadAverageText();

} // namespace volcl::cli
