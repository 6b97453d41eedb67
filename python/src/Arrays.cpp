// Conversions between volcl volumes/images and numpy arrays: outputs hand the C++ buffer to numpy.
#include "python/src/Bindings.hpp"

#include "core/Error.hpp"

#include <cmath>
#include <cstring>
#include <memory>

namespace volcl::python {

namespace {

nb::dlpack::dtype dtypeOf(ScalarType type) {
    switch (type) {
    case ScalarType::UInt8:
        return nb::dtype<std::uint8_t>();
    case ScalarType::UInt16:
        return nb::dtype<std::uint16_t>();
    case ScalarType::Int16:
        return nb::dtype<std::int16_t>();
    case ScalarType::Float32:
        return nb::dtype<float>();
    case ScalarType::Float64:
        return nb::dtype<double>();
    }
    return nb::dtype<std::uint8_t>();
}

std::string dtypeName(nb::dlpack::dtype d) {
    const char* kind = d.code == std::uint8_t(nb::dlpack::dtype_code::Int)     ? "int"
                       : d.code == std::uint8_t(nb::dlpack::dtype_code::UInt)  ? "uint"
                       : d.code == std::uint8_t(nb::dlpack::dtype_code::Float) ? "float"
                       : d.code == std::uint8_t(nb::dlpack::dtype_code::Bool)  ? "bool"
                                                                               : "complex";
    return kind + std::to_string(d.bits);
}

template <class T>
nb::object owningArray(std::unique_ptr<T> owner, void* data, std::vector<std::size_t> shape,
                       nb::dlpack::dtype dtype) {
    T* raw = owner.get();
    nb::capsule capsule(raw, [](void* p) noexcept { delete static_cast<T*>(p); });
    owner.release(); // the capsule owns it now
    return nb::ndarray<nb::numpy>(data, shape.size(), shape.data(), capsule, nullptr, dtype).cast();
}

} // namespace

const char* numpyTypeName(ScalarType type) noexcept {
    switch (type) {
    case ScalarType::UInt8:
        return "uint8";
    case ScalarType::UInt16:
        return "uint16";
    case ScalarType::Int16:
        return "int16";
    case ScalarType::Float32:
        return "float32";
    case ScalarType::Float64:
        return "float64";
    }
    return "uint8";
}

nb::object volumeToArray(Volume volume) {
    const Dims d = volume.dims();
    const ScalarType type = volume.type();
    auto owner = std::make_unique<Volume>(std::move(volume));
    void* data = owner->bytes().data();
    return owningArray(std::move(owner), data, {d.z, d.y, d.x}, dtypeOf(type));
}

Volume arrayToVolume(const InputArray& array, const std::array<double, 3>& spacing,
                     const std::array<double, 3>& origin) {
    if (array.ndim() != 3)
        throw UsageError("a volume is a 3D array a[z, y, x]; this one has " + std::to_string(array.ndim()) +
                         " dimensions");
    // The same geometry every file reader requires: a NaN, zero or negative spacing made files that volcl
    // then refused to read.
    for (int a = 0; a < 3; ++a) {
        if (!std::isfinite(spacing[a]) || !(spacing[a] > 0))
            throw UsageError("spacing[" + std::to_string(a) + "] = " + std::to_string(spacing[a]) +
                             " is not a positive finite number");
        if (!std::isfinite(origin[a]))
            throw UsageError("origin[" + std::to_string(a) + "] = " + std::to_string(origin[a]) +
                             " is not finite");
    }
    const Dims dims{array.shape(2), array.shape(1), array.shape(0)};
    const nb::dlpack::dtype d = array.dtype();
    ScalarType type = ScalarType::Float32;
    if (d == nb::dtype<std::uint8_t>())
        type = ScalarType::UInt8;
    else if (d == nb::dtype<std::uint16_t>())
        type = ScalarType::UInt16;
    else if (d == nb::dtype<std::int16_t>())
        type = ScalarType::Int16;
    else if (d == nb::dtype<double>())
        type = ScalarType::Float64;
    else if (!(d == nb::dtype<float>()))
        throw UsageError("array dtype " + dtypeName(d) +
                         " is not a volume type (uint8, uint16, int16, float32, float64)");
    Volume v(dims, type);
    v.spacing = spacing;
    v.origin = origin;
    std::memcpy(v.bytes().data(), array.data(), v.byteSize());
    return v;
}

nb::object imageToArray(ImageBuffer image) {
    const std::vector<std::size_t> shape{std::size_t(image.height), std::size_t(image.width),
                                         image.channels.size()};
    auto owner = std::make_unique<ImageBuffer>(std::move(image));
    void* data = owner->pixels.data();
    return owningArray(std::move(owner), data, shape, nb::dtype<float>());
}

nb::object floatsToArray(std::vector<float> values, std::vector<std::size_t> shape) {
    auto owner = std::make_unique<std::vector<float>>(std::move(values));
    void* data = owner->data();
    return owningArray(std::move(owner), data, std::move(shape), nb::dtype<float>());
}

} // namespace volcl::python
