// `volcl bench`: the group every benchmark hangs under.
#include "apps/bench/BenchCommand.hpp"

namespace volcl::cli {

void addBenchCommand(CLI::App& app, GlobalOptions& global) {
    CLI::App* bench = app.add_subcommand("bench", "Benchmarks: speed and accuracy against peers");
    bench->require_subcommand(1);
    addViewBench(*bench, global);
    addPreintBench(*bench, global);
    addRenderBench(*bench, global);
    addCodecBench(*bench, global);
    addMotionBench(*bench, global);
    addSeriesBench(*bench, global);
}

} // namespace volcl::cli
