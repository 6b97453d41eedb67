// Shared pieces of the Python module: the device context handle, array conversions and each file's binder.
#pragma once

#include "core/Volume.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "host/image/ImageIo.hpp"

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <array>
#include <mutex>
#include <string>
#include <vector>

namespace volcl::python {

namespace nb = nanobind;

/// One OpenCL device context for Python callers. A ComputeContext serves one thread at a time, so every
/// call locks `mutex` (after releasing the GIL, so other Python threads keep running meanwhile).
struct Context {
    explicit Context(const std::string& selector) : cc(selector) {}
    ComputeContext cc;
    std::mutex mutex;
};

/// A C-contiguous CPU array of any dtype, as numpy hands it over.
using InputArray = nb::ndarray<nb::ro, nb::c_contig, nb::device::cpu>;

/// The volume's voxels as a numpy array a[z, y, x] that owns the volume (no copy).
nb::object volumeToArray(Volume volume);
/// A numpy array a[z, y, x] (uint8, uint16, int16, float32, float64) as a Volume on
/// the given grid. Copies the voxels once: a Volume owns its storage. Throws UsageError for other dtypes
/// or shapes.
Volume arrayToVolume(const InputArray& array, const std::array<double, 3>& spacing,
                     const std::array<double, 3>& origin);
/// An image as a float32 numpy array [height, width, channels] that owns the pixels (no copy).
nb::object imageToArray(ImageBuffer image);
/// A float vector as a numpy array of the given shape that owns the values (no copy).
nb::object floatsToArray(std::vector<float> values, std::vector<std::size_t> shape);
/// numpy's name for a scalar type ("uint8", ..., "float32").
const char* numpyTypeName(ScalarType type) noexcept;

void bindIo(nb::module_& m);
void bindCodec(nb::module_& m);
void bindTransferFunction(nb::module_& m);
void bindRender(nb::module_& m);

} // namespace volcl::python
