// The volume model: a dense node-centred 3D scalar grid (x fastest) and time series of such grids.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/ZeroedBytes.hpp"

namespace volcl {

/// Voxel types a volume can hold. Float64 is kept by the readers, the writers and the codec; the OpenCL
/// stages (transforms, renderers) work in float32 and narrow it where they take their input (docs/codec.md,
/// "Float64 volumes").
enum class ScalarType : std::uint8_t { UInt8, UInt16, Int16, Float32, Float64 };

std::size_t scalarSize(ScalarType t) noexcept;
std::string_view scalarTypeName(ScalarType t) noexcept; ///< "uint8", "uint16", "int16", "float32", "float64"
/// True for Float32 and Float64.
constexpr bool isFloatType(ScalarType t) noexcept {
    return t == ScalarType::Float32 || t == ScalarType::Float64;
}
/// Parses "uint8"/"u8"/"uchar", "uint16"/"u16"/"ushort", "int16"/"i16"/"short", "float32"/"float"/"f32",
/// "float64"/"double"/"f64".
/// Throws UsageError on anything else.
ScalarType parseScalarType(std::string_view name);

template <class T> constexpr ScalarType scalarTypeOf();
template <> constexpr ScalarType scalarTypeOf<std::uint8_t>() {
    return ScalarType::UInt8;
}
template <> constexpr ScalarType scalarTypeOf<std::uint16_t>() {
    return ScalarType::UInt16;
}
template <> constexpr ScalarType scalarTypeOf<std::int16_t>() {
    return ScalarType::Int16;
}
template <> constexpr ScalarType scalarTypeOf<float>() {
    return ScalarType::Float32;
}
template <> constexpr ScalarType scalarTypeOf<double>() {
    return ScalarType::Float64;
}

struct Dims {
    std::size_t x = 0, y = 0, z = 0;
    std::size_t count() const noexcept { return x * y * z; }
    bool operator==(const Dims&) const = default;
};

/// A 3x3 matrix stored row by row; as a volume's direction its column c is the world direction of index axis c.
using Direction3 = std::array<double, 9>;
inline constexpr Direction3 kIdentityDirection{1, 0, 0, 0, 1, 0, 0, 0, 1};

/// The orthonormal matrix nearest `m` by Gram-Schmidt on its columns in order (column 0 kept, column 1
/// made orthogonal to it, column 2 to both, all unit length; the handedness of `m` is kept). Throws
/// DataError when a column is zero, not finite or dependent on the others.
Direction3 orthonormalDirection(const Direction3& m);
/// Determinant of a 3x3 matrix: -1 for a direction that mirrors (e.g. LAS index axes in RAS).
double determinant(const Direction3& m) noexcept;

/// Summary statistics over all voxels (NaN voxels are counted, not included in min/max/mean).
struct VolumeStats {
    double min = 0, max = 0, mean = 0, stddev = 0;
    std::size_t nanCount = 0, infCount = 0;
    std::vector<std::uint64_t> histogram; ///< equal-width bins over [min, max]
};

/// A dense 3D grid of scalars. Sample (i,j,k) sits at `origin + (i*sx, j*sy, k*sz)` in the volume's own
/// (index-aligned) frame and is stored at index `i + nx*(j + ny*k)`; `direction` turns that frame about
/// `origin` into world (patient RAS) axes. Example:
/// ```
/// volcl::Volume v({64, 64, 32}, volcl::ScalarType::UInt16);
/// v.values<std::uint16_t>()[v.index(1, 2, 3)] = 7;
/// ```
class Volume {
public:
    Volume() = default;
    /// Zero-filled volume. Throws DataError when a dimension is 0 or the byte size overflows.
    Volume(Dims dims, ScalarType type);

    const Dims& dims() const noexcept { return dims_; }
    ScalarType type() const noexcept { return type_; }
    std::size_t voxelCount() const noexcept { return dims_.count(); }
    std::size_t byteSize() const noexcept { return bytes_.size(); }
    bool empty() const noexcept { return bytes_.empty(); }

    std::array<double, 3> spacing{1.0, 1.0, 1.0};
    std::array<double, 3> origin{0.0, 0.0, 0.0};
    /// Orientation of the index axes in world axes, orthonormal: world = origin + direction *
    /// (diag(spacing) * index). For medical formats world is patient RAS (+x toward the patient's right,
    /// +y anterior, +z superior); readers of LPS files convert the directions (origin stays as the file
    /// states it). Identity when the file states none.
    Direction3 direction = kIdentityDirection;
    /// The file placed the volume in patient axes (NIfTI, NRRD with an anatomical `space`, MetaImage
    /// with a direction): named views then mean patient sides (front = anterior) and are the default.
    bool anatomical = false;

    std::size_t index(std::size_t i, std::size_t j, std::size_t k) const noexcept {
        return i + dims_.x * (j + dims_.y * k);
    }

    /// Typed view; throws DataError if T does not match type().
    template <class T> std::span<T> values() {
        checkType(scalarTypeOf<T>());
        return {reinterpret_cast<T*>(bytes_.data()), voxelCount()};
    }
    template <class T> std::span<const T> values() const {
        checkType(scalarTypeOf<T>());
        return {reinterpret_cast<const T*>(bytes_.data()), voxelCount()};
    }
    std::span<std::byte> bytes() noexcept { return bytes_; }
    std::span<const std::byte> bytes() const noexcept { return bytes_; }

    /// Value of voxel n as double, whatever the type.
    double valueAt(std::size_t n) const noexcept;
    /// All voxels as float (for kernels that take float input).
    std::vector<float> toFloat() const;
    /// Converts to another type. Values outside the target range are clamped; float->int rounds to nearest.
    Volume convertedTo(ScalarType target) const;
    /// Sub-volume [lo, hi) in voxel indices; spacing kept, origin moved. Throws UsageError if out of range.
    Volume cropped(Dims lo, Dims hi) const;

    VolumeStats stats(std::size_t histogramBins = 16) const;
    /// True when grid (dims, type, spacing, origin, direction) matches.
    bool sameGrid(const Volume& o) const noexcept;
    bool operator==(const Volume& o) const noexcept { return sameGrid(o) && bytes_ == o.bytes_; }

private:
    void checkType(ScalarType t) const;
    Dims dims_{};
    ScalarType type_ = ScalarType::UInt8;
    ZeroedBytes bytes_;
};

/// An ordered list of volumes on one grid. A plain 3D file reads as a series of one frame.
struct TimeSeries {
    std::vector<Volume> frames;
    std::vector<double> times; ///< optional; empty or one per frame
    /// Throws DataError when frames differ in grid.
    void validate() const;
};

} // namespace volcl
