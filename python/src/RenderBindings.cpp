// Rendering and pre-integration for Python: a scene (JSON) over a numpy volume to an RGBA float image, and
// pre-integration tables as arrays.
#include "python/src/Bindings.hpp"

#include "core/Error.hpp"
#include "host/tf/TransferFunction.hpp"
#include "preintegration/PreintegrationTable.hpp"
#include "render/CameraFraming.hpp"
#include "render/RenderInput.hpp"
#include "render/Scene.hpp"
#include "render/VecMath.hpp"

#include <nanobind/stl/array.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

namespace volcl::python {
namespace {

// The image `volcl render` writes to EXR for the same volume, TF and scene: linear associated RGBA (+ Z
// with iso-surfaces), no background; returns (pixels [height, width, channels], channel names). The
// transfer function is `tf` as built, else `tfSpec` (a preset or file) read with the command line's
// automatic opacity unit distance, else ParaView's default over the data range, as `volcl render` does.
std::tuple<nb::object, std::vector<std::string>>
render(Context& context, const InputArray& array, const std::array<double, 3>& spacing,
       const std::array<double, 3>& origin, const TransferFunction* tf, std::optional<std::string> tfSpec,
       const std::string& sceneJson, std::optional<std::string> view, const Direction3& direction) {
    Volume v = arrayToVolume(array, spacing, origin);
    v.direction = orthonormalDirection(direction);
    ImageBuffer image;
    {
        nb::gil_scoped_release released;
        Scene scene = Scene::fromJson(sceneJson);
        const WorldBox box = volumeBox(v);
        if (view) {
            if (scene.camera) throw UsageError("render: give either camera or view, not both");
            // The view is in world axes (patient RAS for anatomical data), as the command line's --view.
            scene.camera =
                frameOrientedBox(box, v.direction, namedViewDirection(parseNamedView(*view)),
                                 Projection::Orthographic, 30.0, double(scene.width) / double(scene.height));
        }
        applyLightingDefaults(scene);
        const RenderInput input = RenderInput::fromVolume(std::move(v));
        const ValueRange range = input.valueRange();
        // The renderer validates the steps once the default half-voxel step is resolved.
        const std::array<double, 2> dataRange{range.min, range.max};
        const double unit = input.approximateCellLength();
        const TransferFunction fitted =
            tf ? tf->fittedTo(dataRange)
               : TransferFunction::forRender(
                     tfSpec ? std::optional<std::filesystem::path>(*tfSpec) : std::nullopt, dataRange, unit);
        std::lock_guard lock(context.mutex);
        const std::unique_ptr<VolumeRenderer> renderer = input.makeRenderer(context.cc, fitted, scene);
        image = renderer->render();
    }
    std::vector<std::string> channels = image.channels;
    return {imageToArray(std::move(image)), channels};
}

// RGBA table [N, N, 4] (2D: y = front, x = back) or [L, N, N, 4] (3D), with the segment lengths.
std::tuple<nb::object, std::vector<double>>
preintegrationTable(Context* context, const TransferFunction& tf, int size, std::optional<double> step,
                    std::optional<int> lengths, std::optional<double> maxLength, const std::string& axis,
                    const std::string& method, const std::string& precision) {
    TableSpec spec;
    spec.size = size;
    if (step.has_value() == (lengths.has_value() || maxLength.has_value()))
        throw UsageError("preint: give either --step (2D) or --lengths and --max-length (3D)");
    if (step) {
        spec.step = *step;
    } else {
        if (axis != "linear" && axis != "exponential")
            throw UsageError("--length-axis must be 'linear' or 'exponential'");
        spec.axis = axis == "linear" ? LengthAxis::Linear : LengthAxis::Exponential;
        spec.lengths = lengths.value_or(0);
        spec.maxLength = maxLength.value_or(0.0);
    }
    spec.validate();
    GeneratorOptions o;
    o.method = parseMethod(method);
    if (precision != "float" && precision != "double")
        throw UsageError("--precision must be 'float' or 'double' (got '" + precision + "')");
    o.precision = precision == "float" ? Precision::Float : Precision::Double;
    if (o.method != PreintMethod::Reference && !context)
        throw UsageError("preint: method '" + method + "' runs on a device and needs a context");
    PreintegrationTable table;
    {
        nb::gil_scoped_release released;
        if (context) {
            std::lock_guard lock(context->mutex);
            table = generatePreintegrationTable(tf, spec, o, &context->cc);
        } else {
            table = generatePreintegrationTable(tf, spec, o, nullptr);
        }
    }
    const std::size_t n = std::size_t(table.size()), slices = std::size_t(table.sliceCount());
    std::vector<std::size_t> shape =
        step ? std::vector<std::size_t>{n, n, 4} : std::vector<std::size_t>{slices, n, n, 4};
    return {floatsToArray(std::move(table.rgba), std::move(shape)), table.lengthValues};
}

// The PNG `volcl render` writes, before 8-bit quantisation: RGBA [height, width, 4+] over `background`, sRGB.
nb::object
compositeOverBackground(const nb::ndarray<const float, nb::ndim<3>, nb::c_contig, nb::device::cpu>& rgba,
                        const std::array<double, 4>& background) {
    if (rgba.shape(2) < 4) throw UsageError("composite: the image needs 4 channels (R, G, B, A)");
    const int width = int(rgba.shape(1)), height = int(rgba.shape(0));
    const std::size_t channels = rgba.shape(2);
    ImageBuffer src(width, height, {"R", "G", "B", "A"});
    for (std::size_t p = 0; p < std::size_t(width) * std::size_t(height); ++p)
        for (std::size_t c = 0; c < 4; ++c)
            src.pixels[p * 4 + c] = rgba.data()[p * channels + c];
    return imageToArray(compositeOverSrgb(src, background));
}

} // namespace

void bindRender(nb::module_& m) {
    m.def("render", &render, nb::arg("context"), nb::arg("array"), nb::arg("spacing"), nb::arg("origin"),
          nb::arg("tf").none(), nb::arg("tf_spec").none(), nb::arg("scene_json"), nb::arg("view").none(),
          nb::arg("direction") = kIdentityDirection);
    m.def("composite", &compositeOverBackground, nb::arg("rgba"), nb::arg("background"));
    m.def("preintegration_table", &preintegrationTable, nb::arg("context").none(), nb::arg("tf"),
          nb::arg("size"), nb::arg("step").none(), nb::arg("lengths").none(), nb::arg("max_length").none(),
          nb::arg("axis"), nb::arg("method"), nb::arg("precision"));
}

} // namespace volcl::python
