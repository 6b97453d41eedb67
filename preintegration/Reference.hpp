// Double-precision reference integration of segments through a piecewise-linear transfer function (internal).
#pragma once

#include <array>
#include <functional>
#include <vector>

namespace volcl {

class TransferFunction;

namespace preint {

/// Table node i of n over `domain` (node-centred, both ends exact): the one definition kernels mirror.
inline double nodeValue(const std::array<double, 2>& domain, int n, int i) {
    return i == n - 1 ? domain[1] : domain[0] + i * (domain[1] - domain[0]) / (n - 1);
}

/// One linear piece of the TF along a segment: width h as a fraction of the segment, values at both ends
/// (one-sided limits, so steps are exact), position w0 of its start in [0, 1].
struct Piece {
    double w0 = 0.0, h = 0.0;
    double tauA = 0.0, tauB = 0.0;
    std::array<double, 3> cA{}, cB{};
};

/// The pieces a segment from sFront to sBack passes, in order from the front. `breakpoints` must be
/// TransferFunction::breakpoints() (passed in so tables compute it once). For sFront == sBack one piece of
/// width 1 with the value at s (the earlier value at a step).
std::vector<Piece> segmentPieces(const TransferFunction& tf, const std::vector<double>& breakpoints,
                                 double sFront, double sBack);

/// {r, g, b, alpha} of a segment of `length` over `pieces` (exact up to the adaptive quadrature, ~1e-13).
std::array<double, 4> integratePieces(const std::vector<Piece>& pieces, double length);

/// Adaptive Gauss-Kronrod (7/15) of a vector integrand over [a, b]: stops when the estimated error of
/// every component is below absTol + relTol * |integral|.
template <std::size_t K>
std::array<double, K> gaussKronrod(const std::function<std::array<double, K>(double)>& f, double a, double b,
                                   double absTol, double relTol);

} // namespace preint
} // namespace volcl
