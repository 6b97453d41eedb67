// One worked example per product subcommand, shown at the foot of its --help (`volcl bench` sets its own).
#include "apps/cli/CliParsing.hpp"
#include "apps/cli/Commands.hpp"

#include <map>
#include <string>

namespace volcl::cli {
namespace {

const std::map<std::string, std::string>& examples() {
    static const std::map<std::string, std::string> table{
        {"volcl", "  volcl demo\n  volcl render --volume head.nii.gz --tf preset:cool-to-warm --view front "
                  "-o head.png"},
        {"info",
         "  volcl info head.nii.gz\n  volcl info series.vcz --bricks\n  volcl info series.vcz --json"},
        {"devices", "  volcl devices"},
        {"convert", "  volcl convert grid0.vdb --replace-nan 0 -o grid0.nrrd\n"
                    "  volcl convert in.raw --dims 64,64,64 --type uint8 -o out.nrrd\n"
                    "  volcl convert head.nii.gz -o head.vti"},
        {"demo", "  volcl demo -o volcl-demo"},
        {"generate", "  volcl generate cloud -o cloud.nrrd --size 256,256,64 --seed 7"},
        {"generate cloud", "  volcl generate cloud -o cloud.nrrd --seed 7\n  volcl generate cloud --preset "
                           "roettger -o layer.nrrd"},
        {"preint", "  volcl preint --tf tf.json --step 0.5 -o table.exr"},
        {"encode", "  volcl encode head.nii.gz -o head.vcz --lossless\n  volcl encode head.nii.gz -o "
                   "head.vcz --psnr 50"},
        {"decode", "  volcl decode head.vcz -o head.nrrd\n  volcl decode head.vcz --level 1 -o half.nrrd\n"
                   "  volcl decode head.vcz -o head.nii.gz"},
        {"compare", "  volcl compare head.nii.gz head.vcz\n  volcl compare head.nii.gz head.vcz --level 1"},
        {"render", "  volcl render --volume head.nii.gz --tf preset:viridis -o head.png\n"
                   "  volcl render --volume head.nii.gz --tf pv.json --orbit 30,20 --shading 0.2,0.7,0.3,32 "
                   "-o lit.png\n"
                   "  volcl render --volume head.nii.gz --mode iso --iso 80 --view iso -o surface.png\n"
                   "  volcl render --volume head.nii.gz --mode iso --iso 80 --smoothing 1 -o smooth.png\n"
                   "  volcl render --volume head.nii.gz --mode mip --window 110,40 -o mip.png"},
        {"view", "  volcl view head.nii.gz --tf preset:cool-to-warm\n"
                 "  volcl view scene.json --headless --frames 8 --stats frames.csv"},
    };
    return table;
}

void addFooter(CLI::App& app, const std::string& key) {
    const auto it = examples().find(key);
    if (it != examples().end()) setExamples(app, it->second);
}

} // namespace

void addHelpExamples(CLI::App& app) {
    addFooter(app, "volcl");
    for (CLI::App* sub : app.get_subcommands({})) {
        addFooter(*sub, sub->get_name());
        for (CLI::App* inner : sub->get_subcommands({}))
            addFooter(*inner, sub->get_name() + " " + inner->get_name());
    }
}

} // namespace volcl::cli
