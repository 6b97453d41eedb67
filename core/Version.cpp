// The library's version string (VOLCL_VERSION is the CMake project version, passed at build time).
#include "core/Version.hpp"

namespace volcl {

std::string_view version() {
    return VOLCL_VERSION;
}

} // namespace volcl
