// `volcl bench`: the benchmarks module of the volcl executable, one add* function per area.
#pragma once

#include "apps/cli/Commands.hpp"

#include <CLI/CLI.hpp>

namespace volcl::cli {

/// Adds the `bench` subcommand and every benchmark under it to `app` (main() calls it when the executable is
/// built with the module, VOLCL_BUILD_BENCH).
void addBenchCommand(CLI::App& app, GlobalOptions& global);

// Each adds its subcommand to `bench`; callbacks throw volcl::Error subclasses like the product commands.
void addViewBench(CLI::App& bench, GlobalOptions& global);   // bench view (ViewBench.cpp)
void addPreintBench(CLI::App& bench, GlobalOptions& global); // bench preint (PreintBench.cpp)
void addRenderBench(CLI::App& bench, GlobalOptions& global); // bench render (RenderBench.cpp, *Bench.cpp)
void addCodecBench(CLI::App& bench, GlobalOptions& global);  // bench codec (CodecBench.cpp, CodecPeers.cpp)
void addMotionBench(CLI::App& bench, GlobalOptions& global); // bench motion (MotionBench.cpp)
void addSeriesBench(CLI::App& bench, GlobalOptions& global); // bench series (SeriesBench.cpp)
void addMeshCodecBench(CLI::App& bench, GlobalOptions& global); // bench mesh-codec (MeshCodecBench.cpp)
void addMeshBench(CLI::App& bench, GlobalOptions& global);      // bench mesh (MeshSortBench.cpp)

} // namespace volcl::cli
