// Where the benchmarks' tables go: a file given by --csv/--json (written atomically), else stdout.
#include "apps/bench/BenchOutput.hpp"

#include "core/AtomicFile.hpp"

#include <iostream>

namespace volcl::cli {

void writeOutput(const std::string& path, const std::string& text) {
    if (path.empty()) {
        std::cout << text;
        return;
    }
    AtomicFile f(path);
    f.write(text);
    f.commit();
}

} // namespace volcl::cli
