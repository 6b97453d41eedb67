// `volcl bench render --skip-sweep`: skipping auto/on/off per step, interleaved rounds, medians, load.
#include "apps/bench/SkipBench.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/runtime/Timing.hpp"
#include "render/VolumeRenderer.hpp"

#include <array>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

namespace volcl::cli {

void benchSkipping(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                   const Scene& scene, const SkipBenchOptions& o) {
    if (o.steps.empty() || o.rounds < 1)
        throw UsageError("bench render: --skip-sweep needs steps and rounds >= 1");
    const std::array<SkipMode, 3> modes{SkipMode::Auto, SkipMode::On, SkipMode::Off};
    std::cout << "empty-space skipping, " << scene.width << "x" << scene.height << ", medians of " << o.rounds
              << " interleaved rounds (kernel ms); load " << loadAverageText() << '\n';
    std::cout << "   step      auto        on       off  auto/best  auto - best (95% interval)  auto chose\n";
    std::ostringstream csv;
    csv << "step,mode,median_ms,lo_ms,hi_ms,choice\n";
    for (double step : o.steps) {
        std::array<std::unique_ptr<VolumeRenderer>, 3> r;
        std::array<std::vector<double>, 3> ms;
        for (std::size_t m = 0; m < modes.size(); ++m) {
            Scene s = scene;
            s.step = step;
            s.skipping = modes[m];
            r[m] = input.makeRenderer(cc, tf, s);
            r[m]->render(); // warm-up: first touch of the output
        }
        for (int round = 0; round < o.rounds; ++round)
            for (std::size_t m = 0; m < modes.size(); ++m) {
                r[m]->render();
                ms[m].push_back(r[m]->lastKernelMilliseconds());
            }
        std::array<MedianInterval, 3> med;
        for (std::size_t m = 0; m < modes.size(); ++m)
            med[m] = medianInterval(ms[m]);
        const std::size_t best = med[1].median <= med[2].median ? 1 : 2;
        std::vector<double> diff;
        for (int k = 0; k < o.rounds; ++k)
            diff.push_back(ms[0][std::size_t(k)] - ms[best][std::size_t(k)]);
        const MedianInterval d = medianInterval(diff);
        const std::string stats = r[0]->statistics();
        const std::size_t at = stats.find("skipping: ");
        const std::string choice = at == std::string::npos ? stats : stats.substr(at + 10);
        std::cout << std::fixed << std::setprecision(2) << std::setw(7) << step << std::setw(10)
                  << med[0].median << std::setw(10) << med[1].median << std::setw(10) << med[2].median
                  << std::setw(11) << std::setprecision(3) << med[0].median / med[best].median << "  "
                  << std::setprecision(2) << std::showpos << std::setw(6) << d.median << " (" << d.lo
                  << " to " << d.hi << ")" << std::noshowpos
                  << (d.holdsZero()  ? " noise"
                      : d.median > 0 ? " SLOWER"
                                     : " faster")
                  << "  " << choice << '\n';
        for (std::size_t m = 0; m < modes.size(); ++m)
            csv << step << ',' << skipModeName(modes[m]) << ',' << med[m].median << ',' << med[m].lo << ','
                << med[m].hi << ",\"" << (m == 0 ? choice : std::string(skipModeName(modes[m]))) << "\"\n";
    }
    std::cout << "load after: " << loadAverageText() << '\n';
    if (!o.csv.empty()) {
        AtomicFile out(o.csv.string());
        out.write(csv.str());
        out.commit();
    }
}

} // namespace volcl::cli
