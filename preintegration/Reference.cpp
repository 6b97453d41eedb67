// Reference segment integration in double: exact piece decomposition, integration by parts, adaptive
// quadrature.
#include "preintegration/Reference.hpp"

#include "host/tf/TransferFunction.hpp"

#include <algorithm>
#include <cmath>

namespace volcl::preint {

namespace {

// Gauss-Kronrod 7/15 nodes and weights on [-1, 1] (positive half; node 0 is the centre).
constexpr double kXk[8] = {0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
                           0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
                           0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
                           0.207784955007898467600689403773245, 0.000000000000000000000000000000000};
constexpr double kWk[8] = {0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
                           0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
                           0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
                           0.204432940075298892414161999234649, 0.209482141084727828012999174891714};
constexpr double kWg[4] = {0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
                           0.381830050505118944950369775488975, 0.417959183673469387755102040816327};

// Transfer-function value (r, g, b, tau) at s.
std::array<double, 4> valueAt(const TransferFunction& tf, double s) {
    auto c = tf.colorAt(s);
    return {c[0], c[1], c[2], tf.extinctionAt(s)};
}

} // namespace

template <std::size_t K>
std::array<double, K> gaussKronrod(const std::function<std::array<double, K>(double)>& f, double a, double b,
                                   double absTol, double relTol) {
    struct Interval {
        double a, b;
        int depth;
    };
    std::array<double, K> total{};
    std::vector<Interval> stack{{a, b, 0}};
    while (!stack.empty()) {
        Interval iv = stack.back();
        stack.pop_back();
        double c = 0.5 * (iv.a + iv.b), r = 0.5 * (iv.b - iv.a);
        std::array<double, K> gauss{}, kronrod{};
        auto fc = f(c);
        for (std::size_t k = 0; k < K; ++k) {
            kronrod[k] = kWk[7] * fc[k];
            gauss[k] = kWg[3] * fc[k];
        }
        for (int i = 0; i < 7; ++i) {
            auto f1 = f(c - r * kXk[i]), f2 = f(c + r * kXk[i]);
            for (std::size_t k = 0; k < K; ++k) {
                kronrod[k] += kWk[i] * (f1[k] + f2[k]);
                if (i % 2 == 1) gauss[k] += kWg[i / 2] * (f1[k] + f2[k]);
            }
        }
        bool ok = iv.depth >= 40;
        if (!ok) {
            ok = true;
            for (std::size_t k = 0; k < K; ++k) {
                double err = std::abs((kronrod[k] - gauss[k]) * r);
                if (err > absTol + relTol * std::abs(kronrod[k] * r)) ok = false;
            }
        }
        if (ok) {
            for (std::size_t k = 0; k < K; ++k)
                total[k] += kronrod[k] * r;
        } else {
            stack.push_back({iv.a, c, iv.depth + 1});
            stack.push_back({c, iv.b, iv.depth + 1});
        }
    }
    return total;
}

template std::array<double, 1> gaussKronrod<1>(const std::function<std::array<double, 1>(double)>&, double,
                                               double, double, double);
template std::array<double, 4> gaussKronrod<4>(const std::function<std::array<double, 4>(double)>&, double,
                                               double, double, double);

std::vector<Piece> segmentPieces(const TransferFunction& tf, const std::vector<double>& breakpoints,
                                 double sFront, double sBack) {
    std::vector<Piece> pieces;
    if (sFront == sBack) {
        auto v = valueAt(tf, sFront);
        Piece p;
        p.h = 1.0;
        p.tauA = p.tauB = std::max(v[3], 0.0);
        p.cA = p.cB = {v[0], v[1], v[2]};
        pieces.push_back(p);
        return pieces;
    }
    double lo = std::min(sFront, sBack), hi = std::max(sFront, sBack);
    std::vector<double> cuts{lo};
    for (double b : breakpoints)
        if (b > lo && b < hi) cuts.push_back(b);
    cuts.push_back(hi);
    double span = hi - lo;
    bool up = sBack > sFront;
    std::size_t count = cuts.size() - 1;
    pieces.reserve(count);
    for (std::size_t q = 0; q < count; ++q) {
        // Walk from the front: upwards the pieces come in ascending order, downwards in descending order.
        std::size_t idx = up ? q : count - 1 - q;
        double s0 = cuts[idx], s1 = cuts[idx + 1];
        // Inside (s0, s1] the TF is linear; its value at s1 is the left limit (the earlier value at a step),
        // and the right limit at s0 is extrapolated through the midpoint so a step at s0 does not leak in.
        auto vHi = valueAt(tf, s1), vMid = valueAt(tf, 0.5 * (s0 + s1));
        std::array<double, 4> vLo;
        for (int c = 0; c < 4; ++c)
            vLo[c] = 2.0 * vMid[c] - vHi[c];
        const auto& va = up ? vLo : vHi;
        const auto& vb = up ? vHi : vLo;
        Piece p;
        p.h = (s1 - s0) / span;
        p.w0 = up ? (s0 - lo) / span : (hi - s1) / span;
        p.tauA = std::max(va[3], 0.0);
        p.tauB = std::max(vb[3], 0.0);
        p.cA = {va[0], va[1], va[2]};
        p.cB = {vb[0], vb[1], vb[2]};
        pieces.push_back(p);
    }
    return pieces;
}

std::array<double, 4> integratePieces(const std::vector<Piece>& pieces, double length) {
    std::array<double, 4> out{0.0, 0.0, 0.0, 0.0};
    if (!(length > 0.0)) return out;
    double depth = 0.0; // optical depth from the front (absolute, includes length)
    for (const Piece& p : pieces) {
        double pa = length * p.h * p.tauA, pb = length * p.h * p.tauB; // depth rates per unit v
        double x = 0.5 * (pa + pb);                                    // depth of the piece
        double tA = std::exp(-depth);
        if (tA > 1e-300) {
            // Per piece (v in [0, 1], t(v) = exp(-D(v)), D(v) = pa v + (pb - pa) v^2 / 2):
            //   int c (-dT) = tA [cA (1 - t(1)) + (cB - cA) int_0^1 (t(v) - t(1)) dv]
            // with t(v) - t(1) written as t(v) * (1 - exp(-(X - D(v)))) so small depths keep full precision.
            double oneMinusT1 = -std::expm1(-x);
            bool colourVaries = p.cA != p.cB;
            double excess = 0.0;
            if (colourVaries && x > 0.0) {
                std::function<std::array<double, 1>(double)> g = [&](double v) -> std::array<double, 1> {
                    double d = v * (pa + 0.5 * (pb - pa) * v);
                    double rest = (1.0 - v) * (pa + 0.5 * (pb - pa) * (1.0 + v));
                    return {std::exp(-d) * -std::expm1(-rest)};
                };
                excess = gaussKronrod<1>(g, 0.0, 1.0, 1e-16, 1e-13)[0];
            }
            for (int c = 0; c < 3; ++c)
                out[c] += tA * (p.cA[c] * oneMinusT1 + (p.cB[c] - p.cA[c]) * excess);
        }
        depth += x;
    }
    out[3] = -std::expm1(-depth);
    return out;
}

} // namespace volcl::preint
