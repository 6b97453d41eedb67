// Pre-integration table model, EXR layout, and the generator that dispatches to the reference or a kernel.
#include "preintegration/PreintegrationTable.hpp"

#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/ParallelFor.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "preintegration/Reference.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <sstream>

namespace volcl {

namespace {

std::string fmt(double v) {
    std::ostringstream ss;
    ss << v;
    return ss.str();
}

// Work-group width along the back index of a table row of n nodes (see DeviceProfile::Preintegration).
std::size_t localX(const ComputeContext& cc, int n) {
    const DeviceProfile::Preintegration& p = cc.profile().preintegration;
    return std::min<std::size_t>(p.rowMax, roundUp(static_cast<std::size_t>(n), p.rowMultiple));
}

// One REAL-typed kernel argument: float or double depending on the precision the kernel was built with.
struct RealArgs {
    bool dbl;
    void set(cl::Kernel& k, cl_uint i, double v) const {
        if (dbl)
            clCheck(k.setArg(i, static_cast<cl_double>(v)), "clSetKernelArg");
        else
            clCheck(k.setArg(i, static_cast<cl_float>(v)), "clSetKernelArg");
    }
    cl::Buffer upload(ComputeContext& cc, const std::vector<double>& values) const {
        if (dbl) return cc.upload<double>(values, CL_MEM_READ_ONLY).get();
        std::vector<float> f(values.begin(), values.end());
        return cc.upload<float>(f, CL_MEM_READ_ONLY).get();
    }
};

KernelDefines realDefines(const GeneratorOptions& o, ComputeContext& cc) {
    KernelDefines d;
    if (o.precision == Precision::Double) {
        if (!cc.device().fp64)
            throw UsageError("--precision double: device " + cc.device().name +
                             " has no double precision support");
        d.set("USE_DOUBLE");
    }
    return d;
}

// Longest segment worth integrating: beyond it, every segment with any extinction is opaque (optical
// depth >= 1e16 per unit of the largest tau) and its colour is that of its first absorbing point to within
// float resolution, so longer lengths give the same entries. Clamping there keeps the kernels' products
// finite (a length of 1e300 is infinite in float) and their work independent of the length.
double saturatedLength(const TransferFunction& tf) {
    const double tauMax = tf.maxExtinction();
    return tauMax > 0.0 ? std::min(1e16 / tauMax, 1e30) : 1.0;
}

// Runs preint_exact for `requested` lengths into `out` (float4 entries, layout of PreintegrationTable).
double runExact(ComputeContext& cc, const TransferFunction& tf, int n, const std::vector<double>& requested,
                double uniformStep, const GeneratorOptions& o, cl::Buffer& out) {
    const std::size_t count = requested.size();
    const double lSat = saturatedLength(tf);
    std::vector<double> lengths(requested);
    for (double& l : lengths)
        if (l > lSat) {
            l = lSat;
            uniformStep = 0.0; // clamped lengths are no longer evenly spaced
        }
    RealArgs real{o.precision == Precision::Double};
    auto knots = tf.packKnots();
    auto knotBuf = cc.upload<VolclTfKnot>(knots, CL_MEM_READ_ONLY);
    if (count == 1) {
        // One length: vectorise across 16 back nodes instead of across lengths.
        KernelDefines defs = realDefines(o, cc);
        defs.set("LANES", 16LL).set("BLOCKS", 1LL);
        cl::Kernel k = cc.kernel("preint/preint.cl", "preint_exact_row", defs);
        clCheck(k.setArg(0, knotBuf.get()), "clSetKernelArg");
        clCheck(k.setArg(1, static_cast<cl_uint>(knots.size())), "clSetKernelArg");
        clCheck(k.setArg(2, static_cast<cl_uint>(n)), "clSetKernelArg");
        real.set(k, 3, tf.domain[0]);
        real.set(k, 4, tf.domain[1]);
        real.set(k, 5, lengths[0]);
        real.set(k, 6, std::max(tf.maxColor(), 0.0));
        real.set(k, 7, o.maxSubstepDepth);
        clCheck(k.setArg(8, out), "clSetKernelArg");
        std::size_t groups = (static_cast<std::size_t>(n) + 15) / 16;
        return eventMilliseconds(cc.launch2d(k, groups, static_cast<std::size_t>(n),
                                             std::min(cc.profile().preintegration.exactRow, groups), 1));
    }
    int lanes = 1;
    while (lanes < 16 && static_cast<std::size_t>(lanes) < count)
        lanes *= 2;
    // Four blocks per work-item: measured 2x faster than 16 on PoCL 3.1 (the state stays in registers), while
    // the TF walk is still shared by 64 lengths.
    int blocks = static_cast<int>(std::min<std::size_t>(4, (count + lanes - 1) / lanes));
    std::size_t chunk = static_cast<std::size_t>(lanes * blocks);
    std::size_t chunks = (count + chunk - 1) / chunk;
    std::vector<double> padded(lengths);
    padded.resize(chunks * chunk, lengths.back());

    KernelDefines defs = realDefines(o, cc);
    defs.set("LANES", static_cast<long long>(lanes)).set("BLOCKS", static_cast<long long>(blocks));
    cl::Kernel k = cc.kernel("preint/preint.cl", "preint_exact", defs);
    cl::Buffer lenBuf = real.upload(cc, padded);
    clCheck(k.setArg(0, knotBuf.get()), "clSetKernelArg");
    clCheck(k.setArg(1, static_cast<cl_uint>(knots.size())), "clSetKernelArg");
    clCheck(k.setArg(2, static_cast<cl_uint>(n)), "clSetKernelArg");
    real.set(k, 3, tf.domain[0]);
    real.set(k, 4, tf.domain[1]);
    clCheck(k.setArg(5, lenBuf), "clSetKernelArg");
    clCheck(k.setArg(6, static_cast<cl_uint>(count)), "clSetKernelArg");
    real.set(k, 7, blocks > 1 ? uniformStep : 0.0);
    real.set(k, 8, std::max(tf.maxColor(), 0.0));
    real.set(k, 9, o.maxSubstepDepth);
    clCheck(k.setArg(10, out), "clSetKernelArg");
    return eventMilliseconds(cc.launch3d(k, static_cast<std::size_t>(n), static_cast<std::size_t>(n), chunks,
                                         localX(cc, n), 1, 1));
}

// Exact cumulative integrals at every node from the domain start: (K_r, K_g, K_b, Phi) with K = int c tau ds
// (c tau is quadratic between breakpoints: Simpson is exact) and Phi = int tau ds (trapezoid is exact).
std::vector<double> nodeIntegrals(const TransferFunction& tf, int n) {
    const double lo = tf.domain[0];
    std::vector<double> bps = tf.breakpoints();
    std::vector<double> out(4 * static_cast<std::size_t>(n), 0.0);
    std::array<double, 4> acc{0, 0, 0, 0};
    double s = lo;
    std::size_t b = 0;
    auto integrate = [&](double a, double c) {
        if (c <= a) return;
        // Limits just inside the piece so that steps at its ends do not leak in.
        auto val = [&](double x) {
            auto col = tf.colorAt(x);
            return std::array<double, 4>{col[0], col[1], col[2], tf.extinctionAt(x)};
        };
        double m = 0.5 * (a + c);
        auto vm = val(m), vc = val(c);
        std::array<double, 4> va;
        for (int q = 0; q < 4; ++q)
            va[q] = 2.0 * vm[q] - vc[q];
        double w = c - a;
        for (int q = 0; q < 3; ++q)
            acc[q] += w / 6.0 * (va[q] * va[3] + 4.0 * vm[q] * vm[3] + vc[q] * vc[3]);
        acc[3] += w * 0.5 * (va[3] + vc[3]);
    };
    for (int i = 0; i < n; ++i) {
        double si = preint::nodeValue(tf.domain, n, i);
        while (b < bps.size() && bps[b] < si) {
            if (bps[b] > s) {
                integrate(s, bps[b]);
                s = bps[b];
            }
            ++b;
        }
        integrate(s, si);
        s = si;
        for (int q = 0; q < 4; ++q)
            out[4 * static_cast<std::size_t>(i) + q] = acc[q];
    }
    return out;
}

std::vector<double> nodeDiagonal(const TransferFunction& tf, int n) {
    std::vector<double> out(4 * static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        double s = preint::nodeValue(tf.domain, n, i);
        auto c = tf.colorAt(s);
        double tau = std::max(tf.extinctionAt(s), 0.0);
        for (int q = 0; q < 3; ++q)
            out[4 * static_cast<std::size_t>(i) + q] = c[q] * tau;
        out[4 * static_cast<std::size_t>(i) + 3] = tau;
    }
    return out;
}

double runIntegralFunction(ComputeContext& cc, const TransferFunction& tf, int n,
                           const std::vector<double>& lengths, const GeneratorOptions& o, cl::Buffer& out) {
    RealArgs real{o.precision == Precision::Double};
    cl::Kernel k = cc.kernel("preint/preint.cl", "preint_integral_function", realDefines(o, cc));
    cl::Buffer integrals = real.upload(cc, nodeIntegrals(tf, n));
    cl::Buffer diag = real.upload(cc, nodeDiagonal(tf, n));
    cl::Buffer lenBuf = real.upload(cc, lengths);
    clCheck(k.setArg(0, integrals), "clSetKernelArg");
    clCheck(k.setArg(1, diag), "clSetKernelArg");
    clCheck(k.setArg(2, static_cast<cl_uint>(n)), "clSetKernelArg");
    real.set(k, 3, tf.domain[0]);
    real.set(k, 4, tf.domain[1]);
    clCheck(k.setArg(5, lenBuf), "clSetKernelArg");
    clCheck(k.setArg(6, static_cast<cl_uint>(lengths.size())), "clSetKernelArg");
    real.set(k, 7, std::max(tf.maxColor(), 0.0));
    clCheck(k.setArg(8, out), "clSetKernelArg");
    return eventMilliseconds(cc.launch3d(k, static_cast<std::size_t>(n), static_cast<std::size_t>(n),
                                         lengths.size(), localX(cc, n), 1, 1));
}

// Chromaticity polynomial (Roettger 9.1): fit through the l -> 0 limit and `degree` exact constant-length
// slices.
double runPolynomial(ComputeContext& cc, const TransferFunction& tf, int n,
                     const std::vector<double>& lengths, const GeneratorOptions& o, cl::Buffer& out) {
    const int deg = o.polynomialDegree;
    const double lMax = lengths.back();
    std::vector<double> fitLengths;
    for (int j = 1; j <= deg; ++j)
        fitLengths.push_back(lMax * j / deg);
    const std::size_t nn = static_cast<std::size_t>(n) * n;
    auto slicesBuf = cc.allocate<cl_float4>(nn * fitLengths.size());
    double ms = runExact(cc, tf, n, fitLengths, lMax / deg, o, slicesBuf.get());
    std::vector<cl_float4> slices = cc.download(slicesBuf);
    std::vector<double> integ = nodeIntegrals(tf, n), diag = nodeDiagonal(tf, n);
    const double ds = (tf.domain[1] - tf.domain[0]) / (n - 1);

    std::vector<cl_float4> coeffs(nn * (deg + 1));
    parallelFor(static_cast<std::size_t>(n), hostThreads(o.threads), [&](std::size_t jf) {
        std::vector<double> x(deg + 1), y(deg + 1);
        for (std::size_t ib = 0; ib < static_cast<std::size_t>(n); ++ib) {
            double mean[4];
            for (int q = 0; q < 4; ++q)
                mean[q] = ib == jf ? diag[4 * ib + q]
                                   : (integ[4 * ib + q] - integ[4 * jf + q]) /
                                         ((static_cast<double>(ib) - static_cast<double>(jf)) * ds);
            double rhoHat = std::max(mean[3], 0.0);
            cl_float4* c = &coeffs[(jf * n + ib) * (deg + 1)];
            for (int ch = 0; ch < 3; ++ch) {
                // Chromaticity C / alpha at l = 0 (limit: mean(c tau) / mean(tau)) and at the fitted slices.
                double c0 = rhoHat > 0.0 ? mean[ch] / rhoHat : 0.0;
                x[0] = 0.0;
                y[0] = c0;
                for (int j = 0; j < deg; ++j) {
                    const cl_float4& e = slices[(static_cast<std::size_t>(j) * n + jf) * n + ib];
                    x[j + 1] = static_cast<double>(j + 1) / deg;
                    y[j + 1] = e.s[3] > 1e-6f ? e.s[ch] / e.s[3] : c0;
                }
                // Newton divided differences, then expansion into monomial coefficients in l / lMax.
                std::vector<double> dd(y);
                for (int lvl = 1; lvl <= deg; ++lvl)
                    for (int i = deg; i >= lvl; --i)
                        dd[i] = (dd[i] - dd[i - 1]) / (x[i] - x[i - lvl]);
                std::vector<double> poly(deg + 1, 0.0);
                for (int i = deg; i >= 0; --i) {
                    // poly = poly * (t - x_i) + dd_i
                    for (int p = deg; p >= 1; --p)
                        poly[p] = poly[p - 1] - x[i] * poly[p];
                    poly[0] = -x[i] * poly[0];
                    poly[0] += dd[i];
                }
                for (int i = 0; i <= deg; ++i)
                    c[i].s[ch] = static_cast<float>(poly[i]);
            }
            for (int i = 0; i <= deg; ++i)
                c[i].s[3] = 0.0f;
            c[0].s[3] = static_cast<float>(rhoHat);
        }
    });
    auto coeffBuf = cc.upload<cl_float4>(coeffs, CL_MEM_READ_ONLY);
    std::vector<float> lf(lengths.begin(), lengths.end());
    auto lenBuf = cc.upload<float>(lf, CL_MEM_READ_ONLY);
    cl::Kernel k = cc.kernel("preint/preint.cl", "preint_polynomial");
    setArgs(k, coeffBuf, static_cast<cl_uint>(n), static_cast<cl_uint>(deg), static_cast<float>(lMax),
            static_cast<float>(std::max(tf.maxColor(), 0.0)), lenBuf, static_cast<cl_uint>(lengths.size()));
    clCheck(k.setArg(7, out), "clSetKernelArg");
    return ms + eventMilliseconds(cc.launch3d(k, static_cast<std::size_t>(n), static_cast<std::size_t>(n),
                                              lengths.size(), localX(cc, n), 1, 1));
}

void referenceTable(const TransferFunction& tf, PreintegrationTable& t, int threads) {
    const int n = t.spec.size;
    const std::size_t nn = static_cast<std::size_t>(n) * n, slices = t.lengthValues.size();
    const std::vector<double> bps = tf.breakpoints();
    parallelFor(nn, hostThreads(threads), [&](std::size_t pair) {
        int jf = static_cast<int>(pair / n), ib = static_cast<int>(pair % n);
        auto pieces = preint::segmentPieces(tf, bps, t.node(jf), t.node(ib));
        for (std::size_t k = 0; k < slices; ++k) {
            auto v = preint::integratePieces(pieces, t.lengthValues[k]);
            float* e = &t.rgba[(k * nn + pair) * 4];
            for (int c = 0; c < 4; ++c)
                e[c] = static_cast<float>(v[c]);
        }
    });
}

} // namespace

// ---------------------------------------------------------------------------------------------- spec

namespace {
// Longest segment a table may describe (a float attribute holds it); the margin admits 1e30 read back
// from float, which rounds it up to 1.0000000150e30.
constexpr double kMaxLength = 1e30 * (1.0 + 1e-7);
} // namespace

void TableSpec::validate() const {
    if (size < 2 || size > 16384)
        throw UsageError("table size must be between 2 and 16384 (got " + fmt(size) + ")");
    if (axis == LengthAxis::Fixed) {
        // Tables keep their lengths as float EXR attributes: 1e30 stays well inside float's range.
        if (!(step > 0.0) || !(step <= kMaxLength))
            throw UsageError("--step must be a positive length up to 1e30 (got " + fmt(step) + ")");
    } else {
        if (lengths < 1) throw UsageError("--lengths must be at least 1 (got " + fmt(lengths) + ")");
        if (!(maxLength > 0.0) || !(maxLength <= kMaxLength))
            throw UsageError("--max-length must be a positive length up to 1e30 (got " + fmt(maxLength) +
                             ")");
    }
    std::size_t slices = axis == LengthAxis::Fixed ? 1 : static_cast<std::size_t>(lengths);
    if (static_cast<std::size_t>(size) * size * slices > kMaxTableEntries)
        throw UsageError("table of " + fmt(size) + "x" + fmt(size) + "x" + fmt(double(slices)) +
                         " entries is larger than the budget of 2^24 entries (256 MiB)");
}

std::vector<double> TableSpec::lengthValues() const {
    validate();
    if (axis == LengthAxis::Fixed) return {step};
    std::vector<double> l(static_cast<std::size_t>(lengths));
    if (axis == LengthAxis::Linear) {
        for (int k = 0; k < lengths; ++k)
            l[k] = (k + 1) * maxLength / lengths;
    } else {
        // l' = 1 - 2^-l is spread evenly up to l'(maxLength); l = -log2(1 - l').
        double top = -std::expm1(-maxLength * std::log(2.0));
        for (int k = 0; k < lengths; ++k) {
            double lp = (k + 1) * top / lengths;
            l[k] = k + 1 == lengths ? maxLength : -std::log1p(-lp) / std::log(2.0);
        }
    }
    return l;
}

double PreintegrationTable::node(int i) const {
    return preint::nodeValue(domain, spec.size, i);
}

std::array<float, 4> PreintegrationTable::entry(int k, int front, int back) const {
    const std::size_t n = static_cast<std::size_t>(spec.size);
    const float* e = &rgba[((static_cast<std::size_t>(k) * n + front) * n + back) * 4];
    return {e[0], e[1], e[2], e[3]};
}

// ---------------------------------------------------------------------------------------------- names

std::string_view methodName(PreintMethod m) {
    switch (m) {
    case PreintMethod::Reference:
        return "reference";
    case PreintMethod::Exact:
        return "exact";
    case PreintMethod::Incremental:
        return "incremental";
    case PreintMethod::IntegralFunction:
        return "integral-function";
    case PreintMethod::Roettger2d:
        return "roettger-2d";
    case PreintMethod::Polynomial:
        return "polynomial";
    }
    return "unknown";
}

PreintMethod parseMethod(std::string_view name) {
    for (PreintMethod m :
         {PreintMethod::Reference, PreintMethod::Exact, PreintMethod::Incremental,
          PreintMethod::IntegralFunction, PreintMethod::Roettger2d, PreintMethod::Polynomial})
        if (methodName(m) == name) return m;
    throw UsageError("unknown --method '" + std::string(name) +
                     "' (valid: reference, exact, incremental, integral-function, roettger-2d, polynomial)");
}

std::string_view lengthAxisName(LengthAxis a) {
    switch (a) {
    case LengthAxis::Fixed:
        return "fixed";
    case LengthAxis::Linear:
        return "linear";
    case LengthAxis::Exponential:
        return "exponential";
    }
    return "unknown";
}

// ---------------------------------------------------------------------------------------------- EXR

ImageBuffer PreintegrationTable::toImage() const {
    const int n = spec.size;
    ImageBuffer img(n, n * sliceCount(), {"R", "G", "B", "A"});
    img.pixels = rgba;
    img.attributes.push_back(
        {"volcl:domain", std::array<float, 2>{static_cast<float>(domain[0]), static_cast<float>(domain[1])}});
    img.attributes.push_back({"volcl:method", std::string(methodName(method))});
    if (spec.axis == LengthAxis::Fixed) {
        img.attributes.push_back({"volcl:step", static_cast<float>(spec.step)});
    } else {
        img.attributes.push_back({"volcl:lengths", spec.lengths});
        img.attributes.push_back({"volcl:maxLength", static_cast<float>(spec.maxLength)});
        img.attributes.push_back({"volcl:lengthAxis", std::string(lengthAxisName(spec.axis))});
    }
    img.attributes.push_back({"volcl:tf", tfJson});
    return img;
}

PreintegrationTable PreintegrationTable::fromImage(const ImageBuffer& img,
                                                   const std::filesystem::path& name) {
    const std::string where = name.empty() ? std::string("table image") : name.string();
    auto attr = [&](std::string_view key) -> const ImageAttribute& {
        const ImageAttribute* a = img.findAttribute(key);
        if (!a)
            throw IoError(where + ": not a volcl pre-integration table (attribute " + std::string(key) +
                          " missing)");
        return *a;
    };
    auto number = [&](const ImageAttribute& a) -> double {
        if (auto f = std::get_if<float>(&a.value)) return *f;
        if (auto i = std::get_if<int>(&a.value)) return *i;
        throw IoError(where + ": attribute " + a.name + " is not a number");
    };
    PreintegrationTable t;
    const auto* dom = std::get_if<std::array<float, 2>>(&attr("volcl:domain").value);
    if (!dom) throw IoError(where + ": attribute volcl:domain is not a v2f");
    t.domain = {(*dom)[0], (*dom)[1]};
    const auto* m = std::get_if<std::string>(&attr("volcl:method").value);
    if (!m) throw IoError(where + ": attribute volcl:method is not a string");
    try {
        t.method = parseMethod(*m);
    } catch (const UsageError&) {
        throw IoError(where + ": unknown method '" + *m + "' in volcl:method");
    }
    if (const auto* tf = img.findAttribute("volcl:tf"); tf && std::get_if<std::string>(&tf->value))
        t.tfJson = std::get<std::string>(tf->value);
    t.spec.size = img.width;
    if (img.findAttribute("volcl:step")) {
        t.spec.axis = LengthAxis::Fixed;
        t.spec.step = number(attr("volcl:step"));
    } else {
        t.spec.lengths = static_cast<int>(number(attr("volcl:lengths")));
        t.spec.maxLength = number(attr("volcl:maxLength"));
        t.spec.axis = LengthAxis::Linear;
        if (const auto* ax = img.findAttribute("volcl:lengthAxis")) {
            const auto* s = std::get_if<std::string>(&ax->value);
            if (s && *s == "exponential")
                t.spec.axis = LengthAxis::Exponential;
            else if (!s || *s != "linear")
                throw IoError(where + ": volcl:lengthAxis must be 'linear' or 'exponential'");
        }
    }
    if (!(t.domain[0] < t.domain[1])) throw IoError(where + ": volcl:domain must satisfy lo < hi");
    try {
        t.lengthValues = t.spec.lengthValues();
    } catch (const UsageError& e) {
        throw IoError(where + ": invalid table attributes: " + e.what());
    }
    if (img.height != img.width * t.sliceCount())
        throw IoError(where + ": image is " + fmt(img.width) + "x" + fmt(img.height) +
                      " but the attributes describe " + fmt(t.sliceCount()) + " slices of " + fmt(img.width) +
                      "x" + fmt(img.width));
    int r = -1, g = -1, b = -1, a = -1;
    for (int c = 0; c < img.channelCount(); ++c) {
        if (img.channels[c] == "R") r = c;
        if (img.channels[c] == "G") g = c;
        if (img.channels[c] == "B") b = c;
        if (img.channels[c] == "A") a = c;
    }
    if (r < 0 || g < 0 || b < 0 || a < 0) throw IoError(where + ": channels R, G, B, A required");
    const std::size_t count = static_cast<std::size_t>(img.width) * img.height;
    t.rgba.resize(count * 4);
    const int nc = img.channelCount();
    for (std::size_t p = 0; p < count; ++p) {
        t.rgba[4 * p + 0] = img.pixels[p * nc + r];
        t.rgba[4 * p + 1] = img.pixels[p * nc + g];
        t.rgba[4 * p + 2] = img.pixels[p * nc + b];
        t.rgba[4 * p + 3] = img.pixels[p * nc + a];
    }
    return t;
}

void PreintegrationTable::writeExr(const std::filesystem::path& path, bool halfFloat) const {
    ImageWriteOptions o;
    o.halfFloat = halfFloat;
    writeImage(toImage(), path, o);
}

PreintegrationTable PreintegrationTable::readExr(const std::filesystem::path& path) {
    return fromImage(readImage(path), path);
}

// ---------------------------------------------------------------------------------------------- generator

struct PreintegrationGenerator::Buffers {
    // `table` wraps the output vector's own memory (CL_MEM_USE_HOST_PTR): on CPU devices the kernel writes
    // straight into it and mapping replaces the copy. Rebuilt when the vector moves or grows.
    DeviceBuffer<cl_float4> table, scratch;
    const float* tableHost = nullptr;
};

PreintegrationGenerator::PreintegrationGenerator(ComputeContext* cc)
    : cc_(cc), buffers_(std::make_unique<Buffers>()) {}
PreintegrationGenerator::~PreintegrationGenerator() = default;

void PreintegrationGenerator::generate(const TransferFunction& tf, const TableSpec& spec,
                                       const GeneratorOptions& o, PreintegrationTable& t) {
    tf.validate();
    if (tf.usesGradient())
        throw UsageError("pre-integration tables have no gradient axis: a transfer function with "
                         "gradient_opacity or widgets is point sampled (docs/transfer-functions.md)");
    t.spec = spec;
    t.lengthValues = spec.lengthValues();
    t.domain = tf.domain;
    t.method = o.method;
    t.tfJson = tf.toJson();
    t.deviceMilliseconds = 0.0;
    // The exact kernels take up to 48 / depth sub-pieces per TF piece: the bound keeps that finite.
    if (!(o.maxSubstepDepth >= 1e-3) || !std::isfinite(o.maxSubstepDepth))
        throw UsageError("substep depth must be a finite number >= 0.001 (got " + fmt(o.maxSubstepDepth) +
                         ")");
    if (o.polynomialDegree < 1 || o.polynomialDegree > 6)
        throw UsageError("polynomial degree must be between 1 and 6 (got " + fmt(o.polynomialDegree) + ")");
    const int n = spec.size;
    const std::size_t nn = static_cast<std::size_t>(n) * n, slices = t.lengthValues.size();
    t.rgba.resize(nn * slices * 4);

    if (o.method == PreintMethod::Reference) {
        referenceTable(tf, t, o.threads);
        return;
    }
    if (!cc_) throw UsageError("method " + std::string(methodName(o.method)) + " needs an OpenCL context");
    ComputeContext* cc = cc_;
    if (nn * slices * sizeof(cl_float4) > cc->device().maxAllocBytes)
        throw UsageError("table of " + fmt(double(nn * slices)) +
                         " entries exceeds the device's largest buffer (" +
                         fmt(double(cc->device().maxAllocBytes)) + " bytes)");
    auto ensure = [&](DeviceBuffer<cl_float4>& b, std::size_t count) -> DeviceBuffer<cl_float4>& {
        if (b.size() < count) {
            b = DeviceBuffer<cl_float4>();
            b = cc->allocate<cl_float4>(count);
        }
        return b;
    };
    if (buffers_->tableHost != t.rgba.data() || buffers_->table.size() != nn * slices) {
        buffers_->table = DeviceBuffer<cl_float4>();
        cl_int err = CL_SUCCESS;
        cl::Buffer b(cc->context(), CL_MEM_READ_WRITE | CL_MEM_USE_HOST_PTR, nn * slices * sizeof(cl_float4),
                     t.rgba.data(), &err);
        clCheck(err, "clCreateBuffer(CL_MEM_USE_HOST_PTR)");
        buffers_->table = DeviceBuffer<cl_float4>(b, nn * slices);
        buffers_->tableHost = t.rgba.data();
    }
    auto& out = buffers_->table;
    const double uniform = spec.axis == LengthAxis::Linear ? spec.maxLength / spec.lengths : 0.0;
    double ms = 0.0;
    switch (o.method) {
    case PreintMethod::Exact:
        ms = runExact(*cc, tf, n, t.lengthValues, uniform, o, out.get());
        break;
    case PreintMethod::Incremental: {
        if (spec.axis == LengthAxis::Exponential)
            throw UsageError("method incremental needs a linear length axis (l_k = (k + 1) l_0)");
        ms = runExact(*cc, tf, n, {t.lengthValues.front()}, 0.0, o, out.get());
        cl::Kernel k = cc->kernel("preint/preint.cl", "preint_incremental_slice");
        std::vector<cl::Event> events;
        for (std::size_t s = 1; s < slices; ++s) {
            setArgs(k, static_cast<cl_uint>(n), static_cast<cl_uint>(s));
            clCheck(k.setArg(2, out.get()), "clSetKernelArg");
            events.push_back(
                cc->launch2d(k, static_cast<std::size_t>(n), static_cast<std::size_t>(n), localX(*cc, n), 1));
        }
        for (const auto& e : events)
            ms += eventMilliseconds(e);
        break;
    }
    case PreintMethod::IntegralFunction:
        ms = runIntegralFunction(*cc, tf, n, t.lengthValues, o, out.get());
        break;
    case PreintMethod::Roettger2d: {
        double lBar = 0.0;
        for (double l : t.lengthValues)
            lBar += l;
        lBar /= static_cast<double>(slices);
        auto& base = ensure(buffers_->scratch, nn);
        ms = runExact(*cc, tf, n, {lBar}, 0.0, o, base.get());
        std::vector<float> lf(t.lengthValues.begin(), t.lengthValues.end());
        auto lenBuf = cc->upload<float>(lf, CL_MEM_READ_ONLY);
        cl::Kernel k = cc->kernel("preint/preint.cl", "preint_roettger_linear");
        setArgs(k, base, static_cast<cl_uint>(n), static_cast<float>(lBar), lenBuf,
                static_cast<cl_uint>(slices), out);
        ms += eventMilliseconds(cc->launch3d(k, static_cast<std::size_t>(n), static_cast<std::size_t>(n),
                                             slices, localX(*cc, n), 1, 1));
        break;
    }
    case PreintMethod::Polynomial:
        ms = runPolynomial(*cc, tf, n, t.lengthValues, o, out.get());
        break;
    case PreintMethod::Reference:
        break;
    }
    t.deviceMilliseconds = ms;
    // Map/unmap makes the entries visible in t.rgba (no copy on devices that use the host pointer directly).
    cl_int err = CL_SUCCESS;
    void* p = cc->queue().enqueueMapBuffer(out.get(), CL_TRUE, CL_MAP_READ, 0,
                                           nn * slices * sizeof(cl_float4), nullptr, nullptr, &err);
    clCheck(err, "clEnqueueMapBuffer");
    if (p != t.rgba.data()) std::memcpy(t.rgba.data(), p, nn * slices * sizeof(cl_float4));
    clCheck(cc->queue().enqueueUnmapMemObject(out.get(), p), "clEnqueueUnmapMemObject");
    cc->finish();
}

PreintegrationTable generatePreintegrationTable(const TransferFunction& tf, const TableSpec& spec,
                                                const GeneratorOptions& o, ComputeContext* cc) {
    PreintegrationGenerator gen(cc);
    PreintegrationTable t;
    gen.generate(tf, spec, o, t);
    return t;
}

std::array<double, 4> referenceSegment(const TransferFunction& tf, double sFront, double sBack,
                                       double length) {
    return preint::integratePieces(preint::segmentPieces(tf, tf.breakpoints(), sFront, sBack), length);
}

// ---------------------------------------------------------------------------------------------- errors

TableError compareWithReference(const PreintegrationTable& table, const TransferFunction& tf,
                                std::size_t samples, int threads) {
    const int n = table.size();
    const std::size_t nn = static_cast<std::size_t>(n) * n, total = nn * table.lengthValues.size();
    std::vector<std::size_t> picks;
    if (samples == 0 || samples >= total) {
        picks.resize(total);
        for (std::size_t i = 0; i < total; ++i)
            picks[i] = i;
    } else {
        std::mt19937_64 rng(12345);
        std::uniform_int_distribution<std::size_t> dist(0, total - 1);
        picks.resize(samples);
        for (auto& p : picks)
            p = dist(rng);
        // Always include the diagonal ends and the longest slice's corners, where tables go wrong first.
        picks.push_back(0);
        picks.push_back(total - 1);
    }
    const std::vector<double> bps = tf.breakpoints();
    std::vector<double> err(picks.size()), sq(picks.size());
    std::vector<int> chan(picks.size());
    parallelFor(picks.size(), hostThreads(threads), [&](std::size_t q) {
        std::size_t idx = picks[q], k = idx / nn, pair = idx % nn;
        int jf = static_cast<int>(pair / n), ib = static_cast<int>(pair % n);
        auto ref = preint::integratePieces(preint::segmentPieces(tf, bps, table.node(jf), table.node(ib)),
                                           table.lengthValues[k]);
        const float* e = &table.rgba[idx * 4];
        double worst = 0.0, s2 = 0.0;
        int wc = 0;
        for (int c = 0; c < 4; ++c) {
            double d = std::isfinite(e[c]) ? std::abs(double(e[c]) - ref[c]) : HUGE_VAL;
            if (!(d <= worst)) {
                worst = d;
                wc = c;
            }
            s2 += d * d;
        }
        err[q] = worst;
        sq[q] = s2;
        chan[q] = wc;
    });
    TableError r;
    r.entries = picks.size();
    double s2 = 0.0;
    for (std::size_t q = 0; q < picks.size(); ++q) {
        s2 += sq[q];
        if (!(err[q] <= r.maxAbs)) {
            r.maxAbs = err[q];
            std::size_t idx = picks[q], pair = idx % nn;
            r.worstK = static_cast<int>(idx / nn);
            r.worstFront = static_cast<int>(pair / n);
            r.worstBack = static_cast<int>(pair % n);
            r.worstChannel = chan[q];
        }
    }
    r.rms = std::sqrt(s2 / (4.0 * static_cast<double>(std::max<std::size_t>(picks.size(), 1))));
    return r;
}

TableError compareTables(const PreintegrationTable& table, const std::vector<double>& ref) {
    if (ref.size() != table.rgba.size()) throw UsageError("compareTables: tables differ in size");
    TableError r;
    const std::size_t n = static_cast<std::size_t>(table.size()), nn = n * n;
    double s2 = 0.0;
    for (std::size_t i = 0; i < ref.size(); ++i) {
        double d = std::isfinite(table.rgba[i]) ? std::abs(double(table.rgba[i]) - ref[i]) : HUGE_VAL;
        s2 += d * d;
        if (!(d <= r.maxAbs)) {
            r.maxAbs = d;
            std::size_t idx = i / 4, pair = idx % nn;
            r.worstK = static_cast<int>(idx / nn);
            r.worstFront = static_cast<int>(pair / n);
            r.worstBack = static_cast<int>(pair % n);
            r.worstChannel = static_cast<int>(i % 4);
        }
    }
    r.entries = ref.size() / 4;
    r.rms = std::sqrt(s2 / static_cast<double>(std::max<std::size_t>(ref.size(), 1)));
    return r;
}

} // namespace volcl
