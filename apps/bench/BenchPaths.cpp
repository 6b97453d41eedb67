// Where `volcl bench` finds its peer scripts and the shared data sets by default; the only file that knows
// the source tree (VOLCL_SOURCE_DIR, set by apps/bench/CMakeLists.txt).
#include "apps/bench/BenchPaths.hpp"

#include <cstdlib>

namespace volcl::cli {

std::string peerScriptDir() {
    if (const char* dir = std::getenv("VOLCL_BENCH_DIR"); dir && *dir) return dir;
    return std::string(VOLCL_SOURCE_DIR) + "/bench";
}

std::string defaultSharedDataDir() {
    return std::string(VOLCL_SOURCE_DIR) + "/../shared/data";
}

} // namespace volcl::cli
