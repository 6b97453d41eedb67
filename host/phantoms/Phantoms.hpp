// Analytic test volumes (Marschner-Lobb, 3D Shepp-Logan): OpenCL generators and double-precision references.
#pragma once

#include "core/Volume.hpp"

namespace volcl {

class ComputeContext;

/// Marschner & Lobb's test signal on [-1,1]^3, node-centred (both ends sampled), values in [0, 1].
/// Example: `Volume v = generateMarschnerLobb(cc, {41, 41, 41});`
struct MarschnerLobbParams {
    double fM = 6.0;
    double alpha = 0.25;
};
Volume generateMarschnerLobb(ComputeContext& cc, Dims dims, MarschnerLobbParams p = {});
Volume marschnerLobbReference(Dims dims, MarschnerLobbParams p = {});
double marschnerLobbValue(double x, double y, double z, MarschnerLobbParams p = {});

/// 3D Shepp-Logan head phantom (Kak & Slaney's ten ellipsoids with Toft's higher-contrast intensities),
/// on [-1,1]^3, node-centred, float32 density in [0, 1].
Volume generateSheppLogan(ComputeContext& cc, Dims dims);
Volume sheppLoganReference(Dims dims);
/// Smallest |q - 1| over the ellipsoids at a point, where q is the ellipsoid's quadratic form: samples with
/// a tiny margin sit on a surface, where float and double may legitimately classify differently.
double sheppLoganBoundaryMargin(double x, double y, double z);
/// Node-centred coordinate of sample i of n on [-1, 1].
double phantomCoordinate(std::size_t i, std::size_t n);

} // namespace volcl
