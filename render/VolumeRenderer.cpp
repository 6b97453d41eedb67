// Defaults of the renderer interface.
#include "render/VolumeRenderer.hpp"

#include "core/Error.hpp"

namespace volcl {

ImageBuffer VolumeRenderer::renderPlainBaseline() {
    throw UsageError("this renderer has no effect-free baseline kernel");
}

Scene VolumeRenderer::withView(Scene scene, const Camera& camera, int width, int height, double step) {
    scene.camera = camera;
    scene.width = width;
    scene.height = height;
    scene.step = step;
    return scene;
}

} // namespace volcl
