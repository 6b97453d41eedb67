// Transfer functions for Python: canonical and ParaView JSON, presets, RGBA strips, exact evaluation.
#include "python/src/Bindings.hpp"

#include "host/tf/TransferFunction.hpp"

#include <nanobind/stl/array.h>
#include <nanobind/stl/filesystem.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/string_view.h>
#include <nanobind/stl/vector.h>

namespace volcl::python {

void bindTransferFunction(nb::module_& m) {
    using TF = TransferFunction;
    nb::class_<TF>(m, "TransferFunction", "Piecewise-linear colour c(s) and extinction tau(s) in data units.")
        .def_static("from_file", &TF::fromFile, nb::arg("path"), nb::arg("strip_domain"),
                    nb::arg("opacity_unit_distance"))
        .def_static("from_json", &TF::fromJson, nb::arg("text"), nb::arg("opacity_unit_distance"))
        .def_static("preset", &TF::builtinPreset, nb::arg("name"), nb::arg("opacity_unit_distance"))
        .def_static("preset_names", &TF::builtinPresetNames)
        .def("to_json", &TF::toJson)
        .def("validate", &TF::validate)
        .def("rescaled", &TF::rescaled, nb::arg("range"))
        .def("fitted_to", &TF::fittedTo, nb::arg("data_range"), nb::arg("explicit_range").none())
        .def("color_at", &TF::colorAt, nb::arg("s"))
        .def("extinction_at", &TF::extinctionAt, nb::arg("s"))
        .def_prop_ro("domain", [](const TF& tf) { return tf.domain; })
        .def_prop_ro("normalized", [](const TF& tf) { return tf.normalized; })
        .def_prop_ro("color",
                     [](const TF& tf) {
                         std::vector<std::array<double, 4>> out;
                         for (const ColorPoint& p : tf.color)
                             out.push_back({p.s, p.rgb[0], p.rgb[1], p.rgb[2]});
                         return out;
                     })
        .def_prop_ro("extinction", [](const TF& tf) {
            std::vector<std::array<double, 2>> out;
            for (const ExtinctionPoint& p : tf.extinction)
                out.push_back({p.s, p.tau});
            return out;
        });
}

} // namespace volcl::python
