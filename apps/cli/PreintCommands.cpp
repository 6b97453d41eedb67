// `volcl preint`: build, check, iso and lighting tables.
#include "apps/cli/CliParsing.hpp"
#include "apps/cli/Commands.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/Timing.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "preintegration/PreintegrationTable.hpp"

#include <cstdlib>
#include <iostream>
#include <memory>
#include <sstream>

namespace volcl::cli {

namespace {

Precision parsePrecision(const std::string& p) {
    if (p == "float") return Precision::Float;
    if (p == "double") return Precision::Double;
    throw UsageError("--precision must be 'float' or 'double' (got '" + p + "')");
}

// "v:r,g,b,a" -> IsoSurface.
IsoSurface parseIso(const std::string& text) {
    IsoSurface s;
    auto colon = text.find(':');
    std::string v = text.substr(0, colon);
    char* end = nullptr;
    s.value = std::strtod(v.c_str(), &end);
    if (v.empty() || *end) throw UsageError("--iso '" + text + "': expected VALUE:R,G,B,A");
    if (colon != std::string::npos) {
        std::stringstream ss(text.substr(colon + 1));
        std::string item;
        int i = 0;
        while (std::getline(ss, item, ',')) {
            if (i >= 4) throw UsageError("--iso '" + text + "': expected four colour components");
            s.rgba[i] = std::strtod(item.c_str(), &end);
            if (item.empty() || *end)
                throw UsageError("--iso '" + text + "': bad colour component '" + item + "'");
            ++i;
        }
        if (i != 4) throw UsageError("--iso '" + text + "': expected four colour components");
    }
    return s;
}

} // namespace

void addPreintCommands(CLI::App& app, GlobalOptions& global) {
    auto* cmd = app.add_subcommand(
        "preint",
        "Build a pre-integration table (2D for --step, 3D for --lengths/--max-length), or --check one");
    struct Args {
        std::string tf, out, check, method = "exact", precision = "float", axis = "linear";
        int size = 256, lengths = 0, degree = 2;
        double step = 0.0, maxLength = 0.0, depth = 1.0;
        bool half = false, lighting = false;
        std::size_t samples = 20000;
        double tolerance = -1.0;
        std::vector<std::string> iso;
        std::vector<double> isoDomain{0.0, 255.0};
    };
    auto a = std::make_shared<Args>();
    cmd->add_option("--tf", a->tf, "Transfer function (canonical JSON, ParaView JSON or RGBA strip)");
    cmd->add_option("--size", a->size, "Table nodes N over the TF domain")->capture_default_str();
    cmd->add_option("--step", a->step, "2D table: segment length");
    cmd->add_option("--lengths", a->lengths, "3D table: number of lengths L");
    cmd->add_option("--max-length", a->maxLength, "3D table: largest length");
    cmd->add_option("--length-axis", a->axis, "3D length axis: linear or exponential (Guthe: l' = 1 - 2^-l)")
        ->capture_default_str();
    cmd->add_option("--method", a->method,
                    "reference, exact, incremental, integral-function, roettger-2d or polynomial")
        ->capture_default_str();
    cmd->add_option("--precision", a->precision, "Kernel arithmetic: float or double")->capture_default_str();
    cmd->add_option("--substep-depth", a->depth, "exact: optical depth per Gauss-Legendre sub-piece")
        ->capture_default_str();
    cmd->add_option("--degree", a->degree, "polynomial: degree in length")->capture_default_str();
    cmd->add_flag("--half", a->half, "Store half floats in the EXR");
    cmd->add_option("--iso", a->iso, "Iso-surface table instead: VALUE:R,G,B,A (associated), repeatable");
    cmd->add_option("--domain", a->isoDomain, "--iso: scalar range LO HI of the table's nodes")
        ->expected(2)
        ->capture_default_str();
    cmd->add_flag("--lighting", a->lighting, "Lighting table instead (Guthe 1.3.4; needs --tf and --step)");
    cmd->add_option("-o,--output", a->out, "Output EXR");
    cmd->add_option("--check", a->check, "Recompute a sample of a table's entries with the reference");
    cmd->add_option("--samples", a->samples, "--check: entries to recompute (0 = all)")
        ->capture_default_str();
    cmd->add_option("--tolerance", a->tolerance, "--check: fail (exit 1) when the max error exceeds this");
    cmd->callback([a, &global] {
        if (!a->check.empty()) {
            if (!a->out.empty() || !a->iso.empty() || a->lighting)
                throw UsageError("--check takes a table and nothing to build");
            auto t = PreintegrationTable::readExr(a->check);
            TransferFunction tf;
            if (!a->tf.empty())
                tf = TransferFunction::fromFile(a->tf);
            else if (!t.tfJson.empty())
                tf = TransferFunction::fromJson(t.tfJson);
            else
                throw IoError(a->check + ": no volcl:tf attribute; pass the transfer function with --tf");
            if (tf.domain[0] != t.domain[0] || tf.domain[1] != t.domain[1])
                throw DataError(a->check + ": the table's domain differs from the transfer function's");
            TableError e = compareWithReference(t, tf, a->samples);
            std::cout << a->check << ": method " << methodName(t.method) << ", " << t.size() << "x"
                      << t.size() << "x" << t.sliceCount() << ", " << e.entries
                      << " entries recomputed with the reference: max error " << e.maxAbs << ", RMS " << e.rms
                      << " (worst: slice " << e.worstK << ", front " << e.worstFront << ", back "
                      << e.worstBack << ", channel "
                      << "RGBA"[e.worstChannel] << ")\n";
            if (a->tolerance >= 0.0 && !(e.maxAbs <= a->tolerance))
                throw DataError(a->check + ": max error " + std::to_string(e.maxAbs) +
                                " exceeds --tolerance " + std::to_string(a->tolerance));
            return;
        }
        if (a->out.empty()) throw UsageError("preint: -o/--output is required (or --check TABLE)");
        if (!a->iso.empty()) {
            if (!a->tf.empty() || a->lighting) throw UsageError("--iso builds a table from iso-values alone");
            std::vector<IsoSurface> surfaces;
            for (const auto& s : a->iso)
                surfaces.push_back(parseIso(s));
            std::array<double, 2> domain{a->isoDomain[0], a->isoDomain[1]};
            writeImage(isoSurfaceTableImage(surfaces, domain, a->size), a->out, {a->half});
            std::cerr << "volcl preint: iso table " << a->size << "x" << a->size << " -> " << a->out << '\n';
            return;
        }
        if (a->tf.empty()) throw UsageError("preint: --tf is required");
        checkNotSameFile(a->tf, a->out);
        TableSpec spec;
        spec.size = a->size;
        bool twoD = a->step != 0.0, threeD = a->lengths != 0 || a->maxLength != 0.0;
        if (twoD == threeD)
            throw UsageError("preint: give either --step (2D) or --lengths and --max-length (3D)");
        if (twoD) {
            spec.step = a->step;
        } else {
            if (a->axis != "linear" && a->axis != "exponential")
                throw UsageError("--length-axis must be 'linear' or 'exponential'");
            spec.axis = a->axis == "linear" ? LengthAxis::Linear : LengthAxis::Exponential;
            spec.lengths = a->lengths;
            spec.maxLength = a->maxLength;
        }
        spec.validate();
        TransferFunction tf = TransferFunction::fromFile(a->tf);
        if (a->lighting) {
            if (!twoD) throw UsageError("--lighting builds a 2D table: give --step");
            writeImage(lightingTableImage(tf, a->size, a->step), a->out, {a->half});
            std::cerr << "volcl preint: lighting table " << a->size << "x" << a->size << " -> " << a->out
                      << '\n';
            return;
        }
        GeneratorOptions o;
        o.method = parseMethod(a->method);
        o.precision = parsePrecision(a->precision);
        o.maxSubstepDepth = a->depth;
        o.polynomialDegree = a->degree;
        std::unique_ptr<ComputeContext> cc;
        if (o.method != PreintMethod::Reference) cc = std::make_unique<ComputeContext>(global.device);
        Stopwatch sw;
        PreintegrationTable t = generatePreintegrationTable(tf, spec, o, cc.get());
        double ms = sw.milliseconds();
        t.writeExr(a->out, a->half);
        std::cerr << "volcl preint: " << methodName(o.method) << " " << spec.size << "x" << spec.size << "x"
                  << t.sliceCount() << " in " << ms << " ms (incl. kernel build) -> " << a->out << '\n';
    });
}

} // namespace volcl::cli
