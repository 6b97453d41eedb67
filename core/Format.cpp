// Number formatting for messages, statistics and tables (core/Format.hpp).
#include "core/Format.hpp"

#include <cmath>
#include <iomanip>
#include <sstream>

namespace volcl {

std::string formatNumber(double v, int precision) {
    std::ostringstream os;
    os.precision(precision);
    os << v;
    return os.str();
}

std::string formatFixed(double v, int digits) {
    if (std::isnan(v)) return "nan"; // not "-nan" for a NaN with its sign bit set
    std::ostringstream os;
    os << std::fixed << std::setprecision(digits) << v;
    return os.str();
}

} // namespace volcl
