// Uses the installed volcl through <volcl/...>: a phantom on the default device against its reference, a PNG
// composite over a scene's background colour, and the library version.
#include <volcl/core/Version.hpp>
#include <volcl/core/Volume.hpp>
#include <volcl/core/runtime/ClRuntime.hpp>
#include <volcl/image/ImageIo.hpp>
#include <volcl/phantoms/Phantoms.hpp>
#include <volcl/render/Scene.hpp>

#include <cmath>
#include <cstdio>
#include <string_view>

int main() {
    volcl::ComputeContext cc;
    volcl::Volume v = volcl::generateMarschnerLobb(cc, {9, 9, 9});
    volcl::Volume r = volcl::marschnerLobbReference({9, 9, 9});
    double err = 0;
    for (std::size_t i = 0; i < v.voxelCount(); ++i)
        err = std::fmax(err, std::fabs(v.valueAt(i) - r.valueAt(i)));

    // Colours are one type across the API: a scene's background goes straight into the PNG composite.
    volcl::Scene scene;
    scene.background = {0.0, 0.0, 1.0, 1.0};
    volcl::ImageBuffer clear(1, 1, {"R", "G", "B", "A"}); // nothing rendered: all zero
    const volcl::ImageBuffer png = volcl::compositeOverSrgb(clear, scene.background);
    const bool blue = png.at(0, 0, 0) == 0.0f && png.at(0, 0, 2) == 1.0f && png.at(0, 0, 3) == 1.0f;

    const bool versionOk = volcl::version() == std::string_view(VOLCL_EXPECTED_VERSION);
    std::printf("consumer: volcl %.*s on %s, phantom max error %.3g, background composite %s\n",
                static_cast<int>(volcl::version().size()), volcl::version().data(), cc.device().name.c_str(),
                err, blue ? "blue" : "wrong");
    return err <= 1e-5 && blue && versionOk ? 0 : 1;
}
