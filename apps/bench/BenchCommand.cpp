// `volcl bench`: the group every benchmark hangs under.
#include "apps/bench/BenchCommand.hpp"
#include "apps/cli/CliParsing.hpp"

#include <utility>

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
    addMeshCodecBench(*bench, global);
    addMeshBench(*bench, global);

    setExamples(*bench, "  volcl bench codec\n  volcl bench view bench/render/mri_scene.json --frames 8");
    const std::pair<const char*, const char*> examples[] = {
        {"codec", "  volcl bench codec --quick"},
        {"preint", "  volcl bench preint --tf tf.json"},
        {"mesh-codec", "  volcl bench mesh-codec --runs 5 --json bench/results/mesh_codec.json"},
        {"render", "  volcl bench render --scene bench/render/mri_scene.json --steps 0.5,1\n"
                   "  volcl bench render --volume head.nii.gz --tf preset:grayscale --mode iso --iso 60.5 "
                   "--filters --no-sweep"},
        {"view", "  volcl bench view bench/render/mri_scene.json --frames 8"},
        {"mesh", "  volcl bench mesh bluntfinxyz.bin combxyz.bin xsmall_turb.vtu --runs 5"},
    };
    for (const auto& [name, text] : examples)
        setExamples(*bench->get_subcommand(name), text);
}

} // namespace volcl::cli
