// Label maps on the grid renderer: the label grid mapped into the intensity grid, its device table, and the
// double-precision classification the kernel (cl/common/labels.h) mirrors.
#pragma once

#include "render/Scene.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace volcl {

class Volume;
class LabelTable;

/// A label volume ready to sample from the intensity grid's voxel coordinates.
struct LabelField {
    std::vector<std::uint16_t> labels;              ///< x fastest
    std::array<std::size_t, 3> dims{};              ///< of the label grid
    std::array<std::array<double, 4>, 3> toLabel{}; ///< label voxel q = toLabel (p, 1), p the intensity voxel
    /// Per label value 0..max, then one entry for "outside the label grid": (r, g, b, w) with w >= 0 a
    /// visible label's extinction per world unit (replace, alone) or its opacity factor (modulate), -1 hidden,
    /// -2 unlabelled.
    std::vector<std::array<float, 4>> table;
    LabelMode mode = LabelMode::Replace;
    bool nearest = false;
    bool sameGrid = false; ///< the label grid is the intensity grid (toLabel is the identity)
    std::size_t outside() const noexcept { return table.size() - 1; }
};

/// The table's w for a hidden label and for an unlabelled one.
inline constexpr float kLabelHidden = -1.0f, kLabelUnlabelled = -2.0f;

/// `labels` (uint8, uint16, int16, or float holding whole numbers 0..65535; DataError naming `name`
/// otherwise) placed by world coordinates (origin, spacing, direction of both volumes) over `intensity`,
/// with `table`'s colours under `layer`'s mode.
LabelField makeLabelField(const Volume& labels, const std::string& name, const LabelTable& table,
                          const LabelLayer& layer, const Volume& intensity);
/// Reads layer.file (and layer.table, else the default palette) and makes the field. Throws what the readers
/// throw, naming the file.
LabelField loadLabelField(const LabelLayer& layer, const Volume& intensity);

/// The kernel's classification in double: the TF's (r, g, b, tau) `tf` at intensity voxel point p turned into
/// the sample's (r, g, b, tau) by the labels. Smooth boundary: each label among the 8 label voxels around q
/// weighs in with g(I) = clamp(2 I - 1/2, 0, 1) of its trilinear indicator I (g(I) + g(1 - I) = 1 between two
/// labels, half of the label's opacity where I = 1/2); the colour is that of the label with the largest
/// indicator among those that add extinction. Nearest: the nearest label voxel's classification.
std::array<double, 4> classifyLabels(const LabelField& field, const std::array<double, 3>& p,
                                     const std::array<double, 4>& tf);

} // namespace volcl
