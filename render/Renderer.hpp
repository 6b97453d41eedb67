// The grid renderer under its first name: `Renderer` is GridRenderer (render/grid/GridRenderer.hpp).
// New code talks to VolumeRenderer (render/VolumeRenderer.hpp) and gets one from RenderInput.
#pragma once

#include "render/grid/GridRenderer.hpp"

namespace volcl {

using Renderer = GridRenderer;

} // namespace volcl
