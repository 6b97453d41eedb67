// Empty-space skipping chosen by measurement: interleaved probe rounds, medians, the fastest wins.
#include "render/SkipChoice.hpp"

#include <algorithm>
#include <cstdio>

namespace volcl {
namespace {

std::string edgeName(unsigned edge) {
    return edge == 0 ? std::string("off") : std::to_string(edge) + "^3";
}

std::string fixed2(double v) {
    char text[48];
    std::snprintf(text, sizeof text, "%.2f", v);
    return text;
}

} // namespace

std::string SkipDecision::text() const {
    std::string s = edge == 0 ? std::string("off") : std::to_string(edge) + "^3-voxel macrocells";
    if (timings.empty()) return s + " (" + unmeasured + ")";
    s += " (auto: " + std::to_string(width) + "x" + std::to_string(height) + " probe, medians of " +
         std::to_string(rounds) + " interleaved rounds, kernel ms:";
    for (std::size_t i = 0; i < timings.size(); ++i) {
        const SkipTiming& t = timings[i];
        s += (i ? ", " : " ") + edgeName(t.candidate.edge) + " " + fixed2(t.ms.median);
        if (t.candidate.edge)
            s += " (" + std::to_string(int(t.candidate.emptyFraction * 100.0 + 0.5)) + "% empty)";
    }
    return s + ")";
}

SkipDecision chooseSkipping(const std::vector<SkipCandidate>& candidates, int rounds,
                            const SkipProbeTimer& time) {
    SkipDecision d;
    std::vector<SkipCandidate> measured{SkipCandidate{}};
    for (const SkipCandidate& c : candidates)
        if (c.edge > 0 && c.emptyFraction > 0.0) measured.push_back(c);
    if (measured.size() == 1) {
        d.unmeasured = "auto: no macrocell is empty, nothing to skip";
        return d;
    }
    d.rounds = std::max(rounds, 1);
    for (const SkipCandidate& c : measured)
        time(c.edge); // warm-up: kernel build, first touch
    std::vector<std::vector<double>> ms(measured.size());
    for (int r = 0; r < d.rounds; ++r)
        for (std::size_t i = 0; i < measured.size(); ++i)
            ms[i].push_back(time(measured[i].edge));
    std::size_t best = 0;
    for (std::size_t i = 0; i < measured.size(); ++i) {
        d.timings.push_back({measured[i], medianInterval(ms[i])});
        if (d.timings[i].ms.median < d.timings[best].ms.median) best = i; // ties: off, then the first edge
    }
    d.edge = measured[best].edge;
    return d;
}

} // namespace volcl
