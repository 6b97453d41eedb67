// Analytic phantoms: ellipsoid table, double references and OpenCL launches.
#include "host/phantoms/Phantoms.hpp"

#include "cl/volcl_shared.h"
#include "core/runtime/ClRuntime.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace volcl {

namespace {

struct EllipsoidParams {
    double value, a, b, c, x0, y0, z0, phiDeg, thetaDeg, psiDeg;
};

// Kak & Slaney's 3D Shepp-Logan ellipsoids with Toft's "modified" intensities (values sum to [0, 1]).
constexpr std::array<EllipsoidParams, 10> kEllipsoids{{
    {1.0, 0.6900, 0.920, 0.810, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
    {-0.8, 0.6624, 0.874, 0.780, 0.0, -0.0184, 0.0, 0.0, 0.0, 0.0},
    {-0.2, 0.1100, 0.310, 0.220, 0.22, 0.0, 0.0, -18.0, 0.0, 10.0},
    {-0.2, 0.1600, 0.410, 0.280, -0.22, 0.0, 0.0, 18.0, 0.0, 10.0},
    {0.1, 0.2100, 0.250, 0.410, 0.0, 0.35, -0.15, 0.0, 0.0, 0.0},
    {0.1, 0.0460, 0.046, 0.050, 0.0, 0.1, 0.25, 0.0, 0.0, 0.0},
    {0.1, 0.0460, 0.046, 0.050, 0.0, -0.1, 0.25, 0.0, 0.0, 0.0},
    {0.1, 0.0460, 0.023, 0.050, -0.08, -0.605, 0.0, 0.0, 0.0, 0.0},
    {0.1, 0.0230, 0.023, 0.020, 0.0, -0.606, 0.0, 0.0, 0.0, 0.0},
    {0.1, 0.0230, 0.046, 0.020, 0.06, -0.605, 0.0, 0.0, 0.0, 0.0},
}};

// z-x-z Euler rotation (phi, theta, psi), the convention of the usual phantom3d tables.
std::array<double, 9> rotation(const EllipsoidParams& e) {
    const double d = std::numbers::pi / 180.0;
    double cphi = std::cos(e.phiDeg * d), sphi = std::sin(e.phiDeg * d);
    double cth = std::cos(e.thetaDeg * d), sth = std::sin(e.thetaDeg * d);
    double cpsi = std::cos(e.psiDeg * d), spsi = std::sin(e.psiDeg * d);
    return {cpsi * cphi - cth * sphi * spsi,
            cpsi * sphi + cth * cphi * spsi,
            spsi * sth,
            -spsi * cphi - cth * sphi * cpsi,
            -spsi * sphi + cth * cphi * cpsi,
            cpsi * sth,
            sth * sphi,
            -sth * cphi,
            cth};
}

double quadraticForm(const EllipsoidParams& e, double x, double y, double z) {
    auto r = rotation(e);
    double qx = r[0] * x + r[1] * y + r[2] * z - e.x0;
    double qy = r[3] * x + r[4] * y + r[5] * z - e.y0;
    double qz = r[6] * x + r[7] * y + r[8] * z - e.z0;
    return qx * qx / (e.a * e.a) + qy * qy / (e.b * e.b) + qz * qz / (e.c * e.c);
}

template <class F> Volume sampleReference(Dims dims, F&& f) {
    Volume v(dims, ScalarType::Float32);
    auto out = v.values<float>();
    for (std::size_t k = 0; k < dims.z; ++k)
        for (std::size_t j = 0; j < dims.y; ++j)
            for (std::size_t i = 0; i < dims.x; ++i)
                out[v.index(i, j, k)] =
                    static_cast<float>(f(phantomCoordinate(i, dims.x), phantomCoordinate(j, dims.y),
                                         phantomCoordinate(k, dims.z)));
    return v;
}

void checkKernelDims(Dims dims) {
    if (dims.x > 0xffffffffu || dims.y > 0xffffffffu || dims.z > 0xffffffffu)
        throw DataError("phantom dimensions exceed 2^32 per axis");
}

} // namespace

double phantomCoordinate(std::size_t i, std::size_t n) {
    return n > 1 ? -1.0 + 2.0 * double(i) / double(n - 1) : 0.0;
}

double marschnerLobbValue(double x, double y, double z, MarschnerLobbParams p) {
    const double pi = std::numbers::pi;
    double r = std::sqrt(x * x + y * y);
    double rr = std::cos(2.0 * pi * p.fM * std::cos(pi * r / 2.0));
    return (1.0 - std::sin(pi * z / 2.0) + p.alpha * (1.0 + rr)) / (2.0 * (1.0 + p.alpha));
}

Volume marschnerLobbReference(Dims dims, MarschnerLobbParams p) {
    return sampleReference(dims,
                           [&](double x, double y, double z) { return marschnerLobbValue(x, y, z, p); });
}

Volume generateMarschnerLobb(ComputeContext& cc, Dims dims, MarschnerLobbParams p) {
    Volume v(dims, ScalarType::Float32);
    checkKernelDims(dims);
    auto out = cc.allocate<float>(v.voxelCount(), CL_MEM_WRITE_ONLY);
    cl::Kernel k = cc.kernel("phantoms/phantoms.cl", "marschner_lobb");
    setArgs(k, out, cl_uint(dims.x), cl_uint(dims.y), cl_uint(dims.z), float(p.fM), float(p.alpha));
    cc.launch3d(k, dims.x, dims.y, dims.z, cc.profile().phantom);
    cc.read(out, v.values<float>());
    return v;
}

double sheppLoganBoundaryMargin(double x, double y, double z) {
    double m = INFINITY;
    for (const auto& e : kEllipsoids)
        m = std::min(m, std::abs(quadraticForm(e, x, y, z) - 1.0));
    return m;
}

Volume sheppLoganReference(Dims dims) {
    return sampleReference(dims, [](double x, double y, double z) {
        double density = 0.0;
        for (const auto& e : kEllipsoids)
            if (quadraticForm(e, x, y, z) <= 1.0) density += e.value;
        return std::max(density, 0.0);
    });
}

Volume generateSheppLogan(ComputeContext& cc, Dims dims) {
    Volume v(dims, ScalarType::Float32);
    checkKernelDims(dims);
    std::vector<VolclEllipsoid> table;
    for (const auto& e : kEllipsoids) {
        VolclEllipsoid el{};
        auto r = rotation(e);
        for (int n = 0; n < 9; ++n)
            el.rot[n] = float(r[n]);
        el.centre[0] = float(e.x0);
        el.centre[1] = float(e.y0);
        el.centre[2] = float(e.z0);
        el.invSemiAxis[0] = float(1.0 / e.a);
        el.invSemiAxis[1] = float(1.0 / e.b);
        el.invSemiAxis[2] = float(1.0 / e.c);
        el.value = float(e.value);
        table.push_back(el);
    }
    auto ellipsoids = cc.upload(table, CL_MEM_READ_ONLY);
    auto out = cc.allocate<float>(v.voxelCount(), CL_MEM_WRITE_ONLY);
    cl::Kernel k = cc.kernel("phantoms/phantoms.cl", "shepp_logan");
    setArgs(k, out, cl_uint(dims.x), cl_uint(dims.y), cl_uint(dims.z), ellipsoids, cl_uint(table.size()));
    cc.launch3d(k, dims.x, dims.y, dims.z, cc.profile().phantom);
    cc.read(out, v.values<float>());
    return v;
}

} // namespace volcl
