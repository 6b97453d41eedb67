// Number formatting for messages, statistics and tables: the one formatter every part of volcl uses.
#pragma once

#include <string>

namespace volcl {

/// `v` as an iostream prints it with `precision` significant digits (the default 6 is iostream's own), so
/// 0.5 is "0.5", 1e-7 is "1e-07" and infinities are "inf".
std::string formatNumber(double v, int precision = 6);

/// `v` with exactly `digits` digits after the point ("3.14" for digits 2); infinities and NaN as "inf",
/// "-inf", "nan".
std::string formatFixed(double v, int digits);

} // namespace volcl
