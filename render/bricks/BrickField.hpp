// The brick renderer's field in plain C++: the node value of every full-resolution voxel when each brick is
// drawn at its own level, as cl/common/brick_sample.h computes it (the reference its kernel is tested
// against).
#pragma once

#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"

#include <cstddef>
#include <vector>

namespace volcl {

class VczReader;

/// Node values of frame `frame` with brick b at level `levels[b]` (-1: its stand-in `standIn[b]` everywhere),
/// as a float32 volume on the file's grid. A node's value is its own brick's level-l approximation there: the
/// trilinear interpolation of the brick's level-l samples at (node - origin) / 2^l, clamped to its last
/// sample. The brick renderer's field is the trilinear interpolation of these node values (so it is
/// continuous across bricks of any levels): a grid render of this volume is the reference of a brick render.
Volume brickNodeValues(ComputeContext& cc, const VczReader& reader, std::size_t frame,
                       const std::vector<int>& levels, const std::vector<float>& standIn);

} // namespace volcl
