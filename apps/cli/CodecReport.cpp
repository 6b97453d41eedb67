// Reporting helpers shared by `volcl encode`/`decode`/`compare` and `volcl bench codec`.
#include "apps/cli/CodecReport.hpp"

#include "core/Format.hpp"

#include <cmath>
#include <iostream>

namespace volcl::cli {

// Stage times of one encode or decode, so speed claims can name their bottleneck.
void printProfile(const char* what, const CodecProfile& p, std::size_t searchTrials) {
    const double staged = p.gather + p.upload + p.transform + p.download + p.entropy + p.reconstruct +
                          p.assemble + p.predict + p.choose;
    std::cerr << "    " << what << " ms: total " << formatFixed(p.total, 1) << " = gather "
              << formatFixed(p.gather, 1) << " upload " << formatFixed(p.upload, 1) << " transform "
              << formatFixed(p.transform, 1) << " download " << formatFixed(p.download, 1) << " entropy "
              << formatFixed(p.entropy, 1) << " reconstruct " << formatFixed(p.reconstruct, 1) << " assemble "
              << formatFixed(p.assemble, 1) << " predict " << formatFixed(p.predict, 1) << " choose "
              << formatFixed(p.choose, 1) << " other " << formatFixed(p.total - staged, 1);
    if (p.trials > 0) std::cerr << " (" << p.trials << " quantisation rounds";
    if (p.sampleTrials > 0) std::cerr << ", " << p.sampleTrials << " on a sample of bricks";
    if (p.trials > 0) std::cerr << ")";
    if (searchTrials > 0) std::cerr << " [target search: " << searchTrials << " rounds, not timed]";
    std::cerr << '\n';
}

nlohmann::json jsonNumber(double v) {
    if (std::isfinite(v)) return v;
    return std::isnan(v) ? nlohmann::json("nan") : nlohmann::json(v > 0 ? "inf" : "-inf");
}

} // namespace volcl::cli
