// Where the benchmarks' tables go (a file given by --csv/--json, written atomically, else stdout) and the
// load they were measured under.
#include "apps/bench/BenchOutput.hpp"

#include "core/AtomicFile.hpp"

#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <sstream>

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

std::string loadAverage() {
    double l[3] = {0, 0, 0};
    if (getloadavg(l, 3) != 3) return "unknown";
    std::ostringstream os;
    os << std::fixed << std::setprecision(2) << l[0] << ", " << l[1] << ", " << l[2];
    return os.str();
}

} // namespace volcl::cli
