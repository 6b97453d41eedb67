// Defaults of the renderer interface.
#include "host/render/VolumeRenderer.hpp"

#include "host/Error.hpp"

namespace volcl {

ImageBuffer VolumeRenderer::renderPlainBaseline() {
    throw UsageError("this renderer has no effect-free baseline kernel");
}

} // namespace volcl
