// The library's version, from the CMake project version it was built with.
#pragma once

#include <string_view>

namespace volcl {

/// "MAJOR.MINOR.PATCH", e.g. "0.1.0"; `volcl --version` prints it.
std::string_view version();

} // namespace volcl
