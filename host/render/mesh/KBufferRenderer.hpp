// The k-buffer (HAVS) renderer of tetrahedral meshes, render.method "kbuffer": its factory.
#pragma once

#include "host/mesh/TetMesh.hpp"
#include "host/render/VolumeRenderer.hpp"

#include <memory>

namespace volcl {

/// A renderer drawing `mesh` (which must outlive it) by sorting its unique faces by centroid and compositing
/// them through per-pixel k-buffers of depth scene.kBufferDepth. RenderInput::makeRenderer calls it for
/// render.method "kbuffer".
std::unique_ptr<VolumeRenderer> makeKBufferRenderer(ComputeContext& cc, const mesh::TetMesh& mesh,
                                                    const TransferFunction& tf, const Scene& scene);

} // namespace volcl
