// The volcl._volcl extension module: exception mapping, devices, contexts, version; other files bind the rest.
#include "python/src/Bindings.hpp"

#include "core/Error.hpp"
#include "core/PrintableMessage.hpp"
#include "core/Version.hpp"

#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <new>
#include <regex>

namespace volcl::python {
namespace {

/// The Python exception classes volcl errors become; kept for the life of the process (the translator
/// refers to them after the module object may be gone).
struct ExceptionTypes {
    PyObject* error = nullptr;
    PyObject* usage = nullptr;
    PyObject* io = nullptr;
    PyObject* data = nullptr;
    PyObject* cl = nullptr;
};

// `bases`: one class, or a tuple (volcl's Error and the builtin class Python code catches).
PyObject* newException(nb::module_& m, const char* name, PyObject* bases, const char* doc) {
    const std::string qualified = std::string("volcl.") + name;
    PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases, nullptr);
    if (!type) throw nb::python_error();
    m.attr(name) = nb::borrow(type);
    return type;
}

// The library's messages name command-line options ("--max-error 0.5 ..."); Python callers pass keyword
// arguments, so each option becomes its keyword: "max_error=0.5 ...", "lossless=True".
std::string pythonNames(const std::string& message) {
    static const std::regex option(R"((^|[\s('"])--([a-z][a-z0-9-]*)( (?=[-0-9.'"]))?)");
    std::string out;
    auto last = message.cbegin();
    for (std::sregex_iterator it(message.begin(), message.end(), option), end; it != end; ++it) {
        const std::smatch& m = *it;
        out.append(last, m[0].first);
        std::string name = m[2].str();
        for (char& c : name)
            if (c == '-') c = '_';
        out += m[1].str();
        if (name == "lossless")
            out += "lossless=True";
        else if (name.starts_with("no_"))
            out += name.substr(3) + "=False";
        else
            out += name + "=";
        if (m[3].matched && name == "lossless") out += ' ';
        last = m[0].second;
    }
    out.append(last, message.cend());
    return out;
}

// The one-line message the command line prints after "volcl: ", options named as Python keywords.
void translate(const std::exception_ptr& p, void* payload) {
    const auto& types = *static_cast<const ExceptionTypes*>(payload);
    try {
        std::rethrow_exception(p);
    } catch (const UsageError& e) {
        PyErr_SetString(types.usage, pythonNames(printableMessage(e.what())).c_str());
    } catch (const IoError& e) {
        PyErr_SetString(types.io, pythonNames(printableMessage(e.what())).c_str());
    } catch (const DataError& e) {
        PyErr_SetString(types.data, pythonNames(printableMessage(e.what())).c_str());
    } catch (const ClError& e) {
        PyErr_SetString(types.cl, pythonNames(printableMessage(e.what())).c_str());
    } catch (const Error& e) {
        PyErr_SetString(types.error, pythonNames(printableMessage(e.what())).c_str());
    } catch (const std::bad_alloc&) {
        PyErr_SetString(PyExc_MemoryError, "out of memory");
    }
}

nb::list devices() {
    nb::list out;
    for (const DeviceInfo& d : listDevices()) {
        nb::dict item;
        item["index"] = d.index;
        item["platform"] = d.platform;
        item["name"] = d.name;
        item["vendor"] = d.vendor;
        item["version"] = d.version;
        item["driver"] = d.driver;
        item["type"] = d.isGpu ? "gpu" : d.isCpu ? "cpu" : "other";
        item["compute_units"] = d.computeUnits;
        item["global_memory"] = d.globalMemBytes;
        item["max_allocation"] = d.maxAllocBytes;
        item["local_memory"] = d.localMemBytes;
        item["max_work_group_size"] = d.maxWorkGroupSize;
        item["fp64"] = d.fp64;
        out.append(item);
    }
    return out;
}

} // namespace
} // namespace volcl::python

NB_MODULE(_volcl, m) {
    using namespace volcl::python;
    m.doc() = "volcl's C++ library bound for Python; the public API is the volcl package around it.";

    auto* types = new ExceptionTypes; // lives as long as the process: see ExceptionTypes
    // Each class also derives from the builtin exception Python code expects for its kind, so `except
    // ValueError` / `except OSError` catch volcl's errors as they catch numpy's and open()'s.
    types->error = newException(m, "Error", PyExc_RuntimeError, "Base of every error volcl raises.");
    const auto bases = [&](PyObject* builtin) { return nb::steal(PyTuple_Pack(2, types->error, builtin)); };
    types->usage = newException(m, "UsageError", bases(PyExc_ValueError).ptr(),
                                "Invalid argument or option combination (the command line's exit code 2); "
                                "a ValueError.");
    types->io = newException(m, "IoError", bases(PyExc_OSError).ptr(),
                             "A file could not be read or written, or is malformed, truncated or corrupted; "
                             "an OSError.");
    types->data = newException(m, "DataError", bases(PyExc_ValueError).ptr(),
                               "Well-formed but unsupported or numerically invalid data (NaN in lossy "
                               "input...); a ValueError.");
    types->cl = newException(m, "ClError", types->error, "An OpenCL call failed.");
    nb::register_exception_translator(translate, types);

    m.def(
        "version", [] { return std::string(volcl::version()); }, "The library version, MAJOR.MINOR.PATCH.");
    m.def("devices", &devices, "Every OpenCL device on every platform, as dicts (volcl devices).");

    nb::class_<Context>(m, "Context", "An OpenCL device context (one per device, shared by the calls).")
        .def(nb::init<const std::string&>(), nb::arg("selector"),
             "selector: '' ($VOLCL_DEVICE or the first device), an index, or a name substring.")
        .def_prop_ro("device_name", [](const Context& c) { return c.cc.device().name; })
        .def_prop_ro("platform_name", [](const Context& c) { return c.cc.device().platform; });

    bindIo(m);
    bindCodec(m);
    bindTransferFunction(m);
    bindRender(m);
}
