// Reporting helpers shared by `volcl encode`/`decode`/`compare` and `volcl bench codec`.
#pragma once

#include "wavelet/CodecTypes.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>

namespace volcl::cli {

/// Prints the stage times of one encode or decode to stderr ("    <what> ms: total ... = gather ..."), so
/// speed claims can name their bottleneck; `searchTrials` > 0 notes the untimed rounds of a rate target's
/// search.
void printProfile(const char* what, const CodecProfile& p, std::size_t searchTrials);

/// A number for JSON output: finite values as they are, NaN and infinities as the strings "nan", "inf",
/// "-inf".
nlohmann::json jsonNumber(double v);

} // namespace volcl::cli
