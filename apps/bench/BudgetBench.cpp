// `volcl bench render --budgets`: planner choices per budget, their interleaved frame times and error.
#include "apps/bench/BudgetBench.hpp"
#include "apps/bench/BenchOutput.hpp"

#include "apps/bench/BenchOutput.hpp"
#include "apps/bench/MeshBench.hpp"
#include "core/Error.hpp"
#include "core/runtime/Timing.hpp"
#include "render/BudgetPlanner.hpp"
#include "render/Reference.hpp"
#include "render/VolumeRenderer.hpp"

#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>

namespace volcl::cli {

void benchBudgets(ComputeContext& cc, const RenderInput& input, const TransferFunction& tf,
                  const Scene& scene, const BudgetBenchOptions& o) {
    if (o.budgetsMs.empty() || o.rounds < 1 || o.referenceSamples < 1)
        throw UsageError("bench render: --budgets needs budgets, rounds >= 1 and reference samples >= 1");
    const std::unique_ptr<VolumeRenderer> r = input.makeRenderer(cc, tf, scene);
    std::cout << "budget planner, " << scene.width << "x" << scene.height << ", load average "
              << loadAverageText() << '\n';
    struct Row {
        double budget;
        std::optional<BudgetChoice> choice;
        std::string refused;
        Scene chosen;
        ImageBuffer image;
        std::vector<double> ms;
    };
    std::vector<Row> rows;
    for (double b : o.budgetsMs) {
        Row row{b, std::nullopt, {}, scene, {}, {}};
        r->setScene(scene);
        try {
            row.choice = fitBudget(*r, b, budgetKnobs(*r, scene), o.runs);
            row.chosen = r->scene();
            std::cout << row.choice->text();
        } catch (const UsageError& e) {
            row.refused = e.what();
            std::cout << "budget " << b << " ms refused: " << row.refused << '\n';
        }
        rows.push_back(std::move(row));
    }

    Scene ref = scene;
    std::string refName;
    Scene traced = scene;
    traced.effects.scatteringOrder = ScatteringOrder::Multiple;
    if (scene.effects.scattering && r->planEffects(traced).pathTracing) {
        ref = traced;
        ref.effects.samples = o.referenceSamples;
        ref.effects.seed = 0x5eedU; // independent of every frame measured
        refName = "path tracer, " + std::to_string(o.referenceSamples) + " samples/pixel, another seed";
    } else {
        ref.step = scene.step / 32.0;
        refName = "ray marcher at step " + std::to_string(ref.step);
    }
    r->setScene(ref);
    const ImageBuffer reference = r->render();

    // Round 0 warms each choice up (and keeps its image); the timed rounds interleave the budgets so that a
    // change of the machine's load touches all of them alike. The scene's own frame (the planner's first
    // probe) is timed in every round too: its ratio to the planner's probes is how much the machine slowed
    // down or sped up between planning and these rounds.
    std::vector<double> anchorMs;
    Scene anchor = scene;
    anchor.effects.scatteringOrder = ScatteringOrder::Single;
    for (int round = 0; round <= o.rounds; ++round) {
        r->setScene(anchor);
        r->render();
        if (round > 0) anchorMs.push_back(r->lastKernelMilliseconds());
        for (Row& row : rows) {
            if (!row.choice) continue;
            r->setScene(row.chosen);
            ImageBuffer img = r->render();
            if (round == 0)
                row.image = std::move(img);
            else
                row.ms.push_back(r->lastKernelMilliseconds());
        }
    }
    // The planner's first probe of each budget is the same frame as the anchor (ray marched at the scene's
    // step).
    std::vector<double> planned;
    for (const Row& row : rows)
        if (row.choice && !row.choice->probes.empty()) planned.push_back(row.choice->probes.front().ms);
    const double drift = planned.empty() ? 1.0 : median(anchorMs) / median(planned);

    std::cout << "reference: " << refName << "; achieved = median of " << o.rounds
              << " interleaved frames; load average now " << loadAverageText()
              << "\nthe scene's own frame: " << std::fixed << std::setprecision(1)
              << (planned.empty() ? 0.0 : median(planned)) << " ms while planning, " << median(anchorMs)
              << " ms in the rounds (machine " << std::setprecision(2) << drift
              << "x as slow); load-corrected = achieved / that factor\n"
              << std::defaultfloat;
    std::cout
        << "  budget_ms  choice                                     planner_ms  achieved_ms   off  within_20%"
           "  load-corrected  expected_rmse  rmse\n";
    std::ofstream csv;
    if (!o.csv.empty()) {
        csv.open(o.csv);
        csv << "budget_ms,knob,value,route,planner_ms,achieved_ms,off_percent,within_20,load_corrected_off_"
               "percent,"
               "expected_rmse,rmse\n";
    }
    for (const Row& row : rows) {
        if (!row.choice) {
            std::cout << "  " << std::setw(9) << row.budget << "  refused\n";
            if (csv.is_open()) csv << row.budget << ",refused,,,,,,,,,\n";
            continue;
        }
        const BudgetChoice& c = *row.choice;
        const double ms = median(row.ms), off = 100.0 * (ms - row.budget) / row.budget,
                     rmse = imageRmse(row.image, reference);
        const double fixedOff = 100.0 * (ms / drift - row.budget) / row.budget;
        std::ostringstream choice;
        choice << c.knob << " " << std::setprecision(4) << c.value;
        std::cout << "  " << std::setw(9) << row.budget << "  " << std::left << std::setw(42) << choice.str()
                  << std::right << std::fixed << std::setprecision(1) << std::setw(10) << c.measuredMs
                  << std::setw(13) << ms << std::setw(6) << std::showpos << off << "%" << std::noshowpos
                  << std::setw(11) << (std::abs(off) <= 20.0 ? "yes" : "no") << std::setw(15) << std::showpos
                  << fixedOff << "%" << std::noshowpos << std::scientific << std::setprecision(2)
                  << std::setw(15) << c.expectedError << std::setw(10) << rmse << std::defaultfloat << '\n';
        if (csv.is_open())
            csv << row.budget << ',' << c.knob << ',' << c.value << ",\"" << c.route << "\"," << c.measuredMs
                << ',' << ms << ',' << off << ',' << (std::abs(off) <= 20.0 ? 1 : 0) << ',' << fixedOff << ','
                << c.expectedError << ',' << rmse << '\n';
    }
    if (csv.is_open() && !csv) throw IoError(o.csv.string() + ": cannot write the budget CSV");
}

} // namespace volcl::cli
