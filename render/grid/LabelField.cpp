// Label maps on the grid renderer: world placement, the device table and the double reference classification.
#include "render/grid/LabelField.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "host/io/VolumeIo.hpp"
#include "host/tf/LabelTable.hpp"
#include "host/tf/TransferFunction.hpp"

#include <algorithm>
#include <cmath>

namespace volcl {
namespace {

/// Label values as uint16; refuses values that are not whole numbers in 0..65535.
std::vector<std::uint16_t> labelValues(const Volume& v, const std::string& name) {
    if (v.type() != ScalarType::UInt8 && v.type() != ScalarType::UInt16 && v.type() != ScalarType::Int16 &&
        v.type() != ScalarType::Float32)
        throw DataError(name + ": a label volume holds integers (uint8, uint16, int16), not " +
                        std::string(scalarTypeName(v.type())));
    const std::vector<float> f = v.toFloat();
    std::vector<std::uint16_t> out(f.size());
    for (std::size_t i = 0; i < f.size(); ++i) {
        const float x = f[i];
        if (!(x >= 0.0f && x <= 65535.0f && x == std::floor(x)))
            throw DataError(name + ": voxel " + std::to_string(i) + " holds " + std::to_string(x) +
                            ", not a label (a whole number in 0..65535)");
        out[i] = static_cast<std::uint16_t>(x);
    }
    return out;
}

/// The device table entry of one label under `mode`.
std::array<float, 4> tableEntry(const LabelTable& t, long label, LabelMode mode) {
    const LabelState st = t.state(label);
    if (st == LabelState::Unlabelled) return {0, 0, 0, kLabelUnlabelled};
    if (st == LabelState::Hidden) return {0, 0, 0, kLabelHidden};
    const LabelEntry e = t.entry(label);
    const double a = e.opacity;
    const double w = mode == LabelMode::Modulate ? a : a >= 1.0 ? kMaxImportedExtinction : -std::log1p(-a);
    return {float(e.rgb[0]), float(e.rgb[1]), float(e.rgb[2]), float(w)};
}

/// Label voxel coordinates of intensity voxel point p: world = O_I + D_I S_I p, q = S_L^-1 D_L^T (world - O_L).
std::array<std::array<double, 4>, 3> labelTransform(const Volume& labels, const Volume& intensity) {
    const Direction3& dl = labels.direction;
    const Direction3& di = intensity.direction;
    std::array<std::array<double, 4>, 3> m{};
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
            double s = 0.0;
            for (int k = 0; k < 3; ++k)
                s += dl[std::size_t(k * 3 + r)] * di[std::size_t(k * 3 + c)];
            m[std::size_t(r)][std::size_t(c)] =
                s * intensity.spacing[std::size_t(c)] / labels.spacing[std::size_t(r)];
        }
        double t = 0.0;
        for (int k = 0; k < 3; ++k)
            t += dl[std::size_t(k * 3 + r)] *
                 (intensity.origin[std::size_t(k)] - labels.origin[std::size_t(k)]);
        m[std::size_t(r)][3] = t / labels.spacing[std::size_t(r)];
    }
    return m;
}

/// The classification a table entry gives a sample whose TF classification is `tf` (cl/common/labels.h's
/// label_class).
std::array<double, 4> labelClass(const std::array<float, 4>& e, LabelMode mode,
                                 const std::array<double, 4>& tf) {
    if (e[3] < -1.5f) return mode == LabelMode::Alone ? std::array<double, 4>{0, 0, 0, 0} : tf;
    if (e[3] < 0.0f) return {0, 0, 0, 0};
    if (mode == LabelMode::Modulate) return {tf[0] * e[0], tf[1] * e[1], tf[2] * e[2], tf[3] * e[3]};
    return {e[0], e[1], e[2], e[3]};
}

} // namespace

LabelField makeLabelField(const Volume& labels, const std::string& name, const LabelTable& table,
                          const LabelLayer& layer, const Volume& intensity) {
    if (labels.empty()) throw DataError(name + ": label volume is empty");
    LabelField f;
    f.labels = labelValues(labels, name);
    f.dims = {labels.dims().x, labels.dims().y, labels.dims().z};
    f.toLabel = labelTransform(labels, intensity);
    f.mode = layer.mode;
    f.nearest = layer.nearest;
    f.sameGrid = labels.dims() == intensity.dims() && labels.spacing == intensity.spacing &&
                 labels.origin == intensity.origin && labels.direction == intensity.direction;
    const std::uint16_t maxLabel = *std::max_element(f.labels.begin(), f.labels.end());
    for (long l = 0; l <= long(maxLabel); ++l)
        f.table.push_back(tableEntry(table, l, layer.mode));
    f.table.push_back({0, 0, 0, kLabelUnlabelled});
    return f;
}

LabelField loadLabelField(const LabelLayer& layer, const Volume& intensity) {
    const Volume labels = readVolume(layer.file);
    const LabelTable table = layer.table.empty() ? LabelTable{} : LabelTable::read(layer.table);
    return makeLabelField(labels, layer.file.string(), table, layer, intensity);
}

std::array<double, 4> classifyLabels(const LabelField& f, const std::array<double, 3>& p,
                                     const std::array<double, 4>& tf) {
    std::array<double, 3> q{};
    for (std::size_t r = 0; r < 3; ++r)
        q[r] = f.toLabel[r][0] * p[0] + f.toLabel[r][1] * p[1] + f.toLabel[r][2] * p[2] + f.toLabel[r][3];
    auto at = [&](long x, long y, long z) -> std::size_t {
        if (x < 0 || y < 0 || z < 0 || x >= long(f.dims[0]) || y >= long(f.dims[1]) || z >= long(f.dims[2]))
            return f.outside();
        return f.labels[(std::size_t(z) * f.dims[1] + std::size_t(y)) * f.dims[0] + std::size_t(x)];
    };
    if (f.nearest)
        return labelClass(f.table[at(long(std::floor(q[0] + 0.5)), long(std::floor(q[1] + 0.5)),
                                     long(std::floor(q[2] + 0.5)))],
                          f.mode, tf);
    const std::array<double, 3> b{std::floor(q[0]), std::floor(q[1]), std::floor(q[2])};
    std::array<std::size_t, 8> l{};
    std::array<double, 8> w{};
    for (int i = 0; i < 8; ++i) {
        const int ox = i & 1, oy = (i >> 1) & 1, oz = i >> 2;
        l[std::size_t(i)] = at(long(b[0]) + ox, long(b[1]) + oy, long(b[2]) + oz);
        const double fx = q[0] - b[0], fy = q[1] - b[1], fz = q[2] - b[2];
        w[std::size_t(i)] = (ox ? fx : 1.0 - fx) * (oy ? fy : 1.0 - fy) * (oz ? fz : 1.0 - fz);
    }
    double tau = 0.0, best = -1.0;
    std::array<double, 3> rgb{0, 0, 0};
    for (std::size_t i = 0; i < 8; ++i) {
        if (std::find(l.begin(), l.begin() + long(i), l[i]) != l.begin() + long(i)) continue; // counted
        double indicator = 0.0;
        for (std::size_t j = i; j < 8; ++j)
            if (l[j] == l[i]) indicator += w[j];
        const std::array<double, 4> e = labelClass(f.table[l[i]], f.mode, tf);
        tau += std::clamp(2.0 * indicator - 0.5, 0.0, 1.0) * e[3];
        if (e[3] > 0.0 && indicator > best) {
            best = indicator;
            rgb = {e[0], e[1], e[2]};
        }
    }
    return {rgb[0], rgb[1], rgb[2], tau};
}

} // namespace volcl
