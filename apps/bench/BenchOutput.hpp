// Where the benchmarks' tables go: a file given by --csv/--json (written atomically), else stdout.
#pragma once

#include <string>

namespace volcl::cli {

/// Writes `text` to `path` through an AtomicFile, or to stdout when `path` is empty.
void writeOutput(const std::string& path, const std::string& text);

} // namespace volcl::cli
