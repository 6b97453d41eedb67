// Fuzz target for scene JSON: parse, validate, and the step checks against a unit volume's diagonal.
#include "core/Error.hpp"
#include "fuzz/FuzzSupport.hpp"
#include "render/Scene.hpp"

#include <cstddef>
#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace volcl;
    try {
        const Scene scene = Scene::fromJson(std::string_view(reinterpret_cast<const char*>(data), size),
                                            fuzz::scratchDirectory());
        scene.validate();
        scene.validateSteps(100.0);
        (void)Scene::fromJson(scene.toJson(), fuzz::scratchDirectory());
    } catch (const Error&) {
    }
    return 0;
}
