// Helpers of the mesh renderer suites: a ramp TF over a mesh's values, framed views, the cell caster's image and
// image checks.
#pragma once

#include "host/image/ImageIo.hpp"
#include "host/mesh/TetMesh.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/CameraFraming.hpp"
#include "render/RenderInput.hpp"
#include "render/VecMath.hpp"
#include "render/mesh/KBufferReference.hpp"
#include "render/mesh/KBufferRenderer.hpp"
#include "render/mesh/MeshReference.hpp"

#include "TestUtil.hpp"

#include <algorithm>
#include <cmath>

namespace volcl::test {

/// Ramp TF over the mesh's value range: blue to orange to white, `depth` optical lengths across the box diagonal
/// at its peak, `floor` of that at the lowest value.
inline TransferFunction meshTf(const mesh::TetMesh& m, double depth, double floor = 0.0) {
    const double lo = m.valueMin, hi = m.valueMax > m.valueMin ? m.valueMax : m.valueMin + 1.0;
    const double diag = norm(sub(m.boundsMax, m.boundsMin));
    TransferFunction tf;
    tf.domain = {lo, hi};
    tf.color = {{lo, {0.1, 0.2, 1.0}}, {0.5 * (lo + hi), {1.0, 0.6, 0.2}}, {hi, {1.0, 1.0, 0.9}}};
    tf.extinction = {{lo, floor * depth / diag},
                     {lo + 0.2 * (hi - lo), std::max(0.1, floor) * depth / diag},
                     {lo + 0.8 * (hi - lo), depth / diag},
                     {hi, 0.3 * depth / diag}};
    return tf;
}

/// The mesh's box framed from (azimuth, elevation), w x h, 3D table with 32 lengths, no early termination.
inline Scene framedMeshScene(const mesh::TetMesh& m, int w, int h, double az, double el, Projection proj) {
    Scene s;
    s.width = w;
    s.height = h;
    s.camera = frameBox(meshBounds(m), orbitDirection(az, el), proj, 35.0, 1.0);
    s.earlyTermination = 1.0;
    s.preintegration = Preintegration::Table3d;
    s.tableLengths = 32;
    return s;
}

/// The exact cell caster's image of `s` (render.method "cells").
inline ImageBuffer cellCasterImage(const mesh::TetMesh& m, const TransferFunction& tf, Scene s) {
    s.meshMethod = MeshMethod::Cells;
    return RenderInput::borrowMesh(m).makeRenderer(computeContext(), tf, s)->render();
}

/// Every channel finite and within [0, 1] (a little float slack above).
inline bool finiteInUnitRange(const ImageBuffer& img) {
    return std::all_of(img.pixels.begin(), img.pixels.end(),
                       [](float v) { return std::isfinite(v) && v >= 0.0f && v <= 1.0f + 1e-5f; });
}

/// Mean of channel A of an RGBA image.
inline double meanAlpha(const ImageBuffer& img) {
    double sum = 0;
    for (std::size_t i = 3; i < img.pixels.size(); i += 4)
        sum += img.pixels[i];
    return sum / double(img.width * img.height);
}

/// The k-buffer mirror's input for the frame `r` last set up: its geometry, faces, parameters, table and k, and
/// the face order of its last frame when the host made it (an exact sort; the centroid order is the mirror's own).
inline KBufferMirrorInput kbufferMirrorInputOf(KBufferRenderer& r) {
    KBufferMirrorInput in;
    in.geometry = &r.geometry();
    in.scalars = &r.geometry().scalars;
    in.faces = &r.faces();
    in.params = r.frameParams();
    in.table = &r.tableValues();
    in.k = r.k();
    in.order = r.hostOrder();
    return in;
}

} // namespace volcl::test
