// The grid renderer under its first name: `Renderer` is GridRenderer (host/render/grid/GridRenderer.hpp).
// New code talks to VolumeRenderer (host/render/VolumeRenderer.hpp) and gets one from RenderInput.
#pragma once

#include "host/render/grid/GridRenderer.hpp"

namespace volcl {

using Renderer = GridRenderer;

} // namespace volcl
