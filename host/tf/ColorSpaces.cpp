// Colour-space conversions and interpolation (RGB, HSV, CIELAB, Msh diverging, step) and their
// piecewise-linear approximation for the kernels' RGB knots.
#include "host/tf/ColorSpaces.hpp"

#include "core/Error.hpp"
#include "host/tf/TransferFunction.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numbers>
#include <string>

namespace volcl {
namespace {

// D65 reference white and the sRGB primaries, to the four decimals ParaView's colour maps are built with.
constexpr double kWhiteX = 0.9505, kWhiteY = 1.0, kWhiteZ = 1.089;

double srgbToLinear(double c) {
    return c > 0.04045 ? std::pow((c + 0.055) / 1.055, 2.4) : c / 12.92;
}
double linearToSrgb(double c) {
    return c > 0.0031308 ? 1.055 * std::pow(c, 1.0 / 2.4) - 0.055 : 12.92 * c;
}
// CIELAB's companding function f(t) and its inverse (the cube root with a linear toe).
double labForward(double t) {
    return t > 0.008856 ? std::cbrt(t) : 7.787 * t + 16.0 / 116.0;
}
double labInverse(double f) {
    const double cube = f * f * f;
    return cube > 0.008856 ? cube : (f - 16.0 / 116.0) / 7.787;
}

// Polar CIELAB: M = |Lab|, s = angle from the L axis (saturation), h = hue angle.
std::array<double, 3> labToMsh(const std::array<double, 3>& lab) {
    const double m = std::sqrt(lab[0] * lab[0] + lab[1] * lab[1] + lab[2] * lab[2]);
    const double s = m > 0.001 ? std::acos(lab[0] / m) : 0.0;
    const double h = s > 0.001 ? std::atan2(lab[2], lab[1]) : 0.0;
    return {m, s, h};
}
std::array<double, 3> mshToLab(const std::array<double, 3>& msh) {
    return {msh[0] * std::cos(msh[1]), msh[0] * std::sin(msh[1]) * std::cos(msh[2]),
            msh[0] * std::sin(msh[1]) * std::sin(msh[2])};
}

/// Angle between two hues, in [0, pi].
double hueDistance(double a, double b) {
    const double d = std::fmod(std::abs(a - b), 2.0 * std::numbers::pi);
    return d > std::numbers::pi ? 2.0 * std::numbers::pi - d : d;
}

/// A hue for an unsaturated end point that keeps the perceived change along the path even (Moreland 2009).
double hueTowardUnsaturated(const std::array<double, 3>& saturated, double unsaturatedM) {
    if (saturated[0] >= unsaturatedM - 0.1) return saturated[2];
    const double spin = saturated[1] * std::sqrt(unsaturatedM * unsaturatedM - saturated[0] * saturated[0]) /
                        (saturated[0] * std::sin(saturated[1]));
    return saturated[2] > -0.3 * std::numbers::pi ? saturated[2] + spin : saturated[2] - spin;
}

Rgb interpolateDiverging(const Rgb& a, const Rgb& b, double t) {
    auto m1 = labToMsh(rgbToLab(a));
    auto m2 = labToMsh(rgbToLab(b));
    // Two distinct saturated ends: go through a neutral white half way, each half its own path.
    if (m1[1] > 0.05 && m2[1] > 0.05 && hueDistance(m1[2], m2[2]) > 0.33 * std::numbers::pi) {
        const double white = std::max({m1[0], m2[0], 88.0});
        if (t < 0.5) {
            m2 = {white, 0.0, 0.0};
            t = 2.0 * t;
        } else {
            m1 = {white, 0.0, 0.0};
            t = 2.0 * t - 1.0;
        }
    }
    if (m1[1] < 0.05 && m2[1] > 0.05)
        m1[2] = hueTowardUnsaturated(m2, m1[0]);
    else if (m2[1] < 0.05 && m1[1] > 0.05)
        m2[2] = hueTowardUnsaturated(m1, m2[0]);
    // The hue angle is interpolated as a plain number, as ParaView (VTK up to 9.5) does: two colours
    // either side of the +-180 degree hue line (teals) run once round the hue circle between them.
    const std::array<double, 3> m{(1 - t) * m1[0] + t * m2[0], (1 - t) * m1[1] + t * m2[1],
                                  (1 - t) * m1[2] + t * m2[2]};
    return labToRgb(mshToLab(m));
}

Rgb interpolateHsv(const Rgb& a, const Rgb& b, double t) {
    auto h1 = rgbToHsv(a), h2 = rgbToHsv(b);
    // The shorter way round the hue circle: move the larger hue down by one turn.
    if (std::abs(h1[0] - h2[0]) > 0.5) (h1[0] > h2[0] ? h1[0] : h2[0]) -= 1.0;
    std::array<double, 3> h{(1 - t) * h1[0] + t * h2[0], (1 - t) * h1[1] + t * h2[1],
                            (1 - t) * h1[2] + t * h2[2]};
    if (h[0] < 0.0) h[0] += 1.0;
    return hsvToRgb(h);
}

double maxChannelGap(const Rgb& a, const Rgb& b) {
    return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
}

Rgb lerp(const Rgb& a, const Rgb& b, double t) {
    return {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
}

/// Appends the interior points of [t0, t1] (f0 = f(t0), f1 = f(t1)) where the chord strays from f by more
/// than `tol`: bisection, checking the midpoint and both quarter points before accepting a chord.
/// Throws DataError once `out` would hold more than `maxPoints`: the caller's share of the piece budget.
template <class F>
void bisect(const F& f, double t0, const Rgb& f0, double t1, const Rgb& f1, double tol, int depth,
            std::vector<std::pair<double, Rgb>>& out, std::size_t maxPoints) {
    const double tm = 0.5 * (t0 + t1);
    const Rgb fm = f(tm);
    constexpr int kMinDepth = 0, kMaxDepth = 12;
    bool straight = depth >= kMinDepth && maxChannelGap(fm, lerp(f0, f1, 0.5)) <= tol;
    if (straight)
        for (double q : {0.25, 0.75})
            straight = straight && maxChannelGap(f(t0 + q * (t1 - t0)), lerp(f0, f1, q)) <= tol;
    if (straight || depth >= kMaxDepth) return;
    bisect(f, t0, f0, tm, fm, tol, depth + 1, out, maxPoints);
    if (out.size() >= maxPoints)
        throw DataError("following the colour space's curves within the tolerance takes more than " +
                        std::to_string(kMaxLinearizedColorPoints) +
                        " linear pieces (the budget of a colour list after interpolation)");
    out.emplace_back(tm, fm);
    bisect(f, tm, fm, t1, f1, tol, depth + 1, out, maxPoints);
}

} // namespace

ColorSpace parseColorSpace(std::string_view name) {
    std::string n(name);
    std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (n == "rgb") return ColorSpace::Rgb;
    if (n == "hsv") return ColorSpace::Hsv;
    if (n == "lab") return ColorSpace::Lab;
    if (n == "diverging") return ColorSpace::Diverging;
    if (n == "step") return ColorSpace::Step;
    throw DataError("colour space '" + std::string(name) +
                    "' is not supported (expected RGB, HSV, Lab, Diverging or Step)");
}

std::string_view colorSpaceName(ColorSpace space) {
    switch (space) {
    case ColorSpace::Rgb:
        return "RGB";
    case ColorSpace::Hsv:
        return "HSV";
    case ColorSpace::Lab:
        return "Lab";
    case ColorSpace::Diverging:
        return "Diverging";
    case ColorSpace::Step:
        return "Step";
    }
    return "RGB";
}

std::array<double, 3> rgbToLab(const Rgb& rgb) {
    const double r = srgbToLinear(rgb[0]), g = srgbToLinear(rgb[1]), b = srgbToLinear(rgb[2]);
    const double x = r * 0.4124 + g * 0.3576 + b * 0.1805;
    const double y = r * 0.2126 + g * 0.7152 + b * 0.0722;
    const double z = r * 0.0193 + g * 0.1192 + b * 0.9505;
    const double fx = labForward(x / kWhiteX), fy = labForward(y / kWhiteY), fz = labForward(z / kWhiteZ);
    return {116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)};
}

Rgb labToRgb(const std::array<double, 3>& lab) {
    const double fy = (lab[0] + 16.0) / 116.0;
    const double x = kWhiteX * labInverse(lab[1] / 500.0 + fy);
    const double y = kWhiteY * labInverse(fy);
    const double z = kWhiteZ * labInverse(fy - lab[2] / 200.0);
    Rgb c{linearToSrgb(x * 3.2406 + y * -1.5372 + z * -0.4986),
          linearToSrgb(x * -0.9689 + y * 1.8758 + z * 0.0415),
          linearToSrgb(x * 0.0557 + y * -0.2040 + z * 1.0570)};
    const double top = std::max({c[0], c[1], c[2]});
    for (double& v : c)
        v = std::max(top > 1.0 ? v / top : v, 0.0);
    return c;
}

std::array<double, 3> rgbToHsv(const Rgb& c) {
    const double hi = std::max({c[0], c[1], c[2]}), lo = std::min({c[0], c[1], c[2]});
    const double s = hi > 0.0 ? (hi - lo) / hi : 0.0;
    double h = 0.0;
    if (s > 0.0) {
        const double span = hi - lo;
        if (c[0] == hi)
            h = (c[1] - c[2]) / (6.0 * span);
        else if (c[1] == hi)
            h = 1.0 / 3.0 + (c[2] - c[0]) / (6.0 * span);
        else
            h = 2.0 / 3.0 + (c[0] - c[1]) / (6.0 * span);
        if (h < 0.0) h += 1.0;
    }
    return {h, s, hi};
}

Rgb hsvToRgb(const std::array<double, 3>& hsv) {
    const double h = hsv[0], s = hsv[1], v = hsv[2];
    // Fully saturated colour of hue h: one channel 1, one 0, one ramping, in six sectors.
    Rgb c{};
    const double sixth = 1.0 / 6.0;
    if (h > sixth && h <= 2 * sixth)
        c = {(2 * sixth - h) / sixth, 1.0, 0.0};
    else if (h > 2 * sixth && h <= 3 * sixth)
        c = {0.0, 1.0, (h - 2 * sixth) / sixth};
    else if (h > 3 * sixth && h <= 4 * sixth)
        c = {0.0, (4 * sixth - h) / sixth, 1.0};
    else if (h > 4 * sixth && h <= 5 * sixth)
        c = {(h - 4 * sixth) / sixth, 0.0, 1.0};
    else if (h > 5 * sixth && h <= 1.0)
        c = {1.0, 0.0, (1.0 - h) / sixth};
    else
        c = {1.0, h / sixth, 0.0};
    for (double& x : c)
        x = v * (s * x + (1.0 - s));
    return c;
}

Rgb interpolateColor(ColorSpace space, const Rgb& a, const Rgb& b, double t) {
    switch (space) {
    case ColorSpace::Rgb:
        return lerp(a, b, t);
    case ColorSpace::Step:
        return t > 0.0 ? b : a;
    case ColorSpace::Hsv:
        return interpolateHsv(a, b, t);
    case ColorSpace::Lab: {
        const auto la = rgbToLab(a), lb = rgbToLab(b);
        return labToRgb(
            {(1 - t) * la[0] + t * lb[0], (1 - t) * la[1] + t * lb[1], (1 - t) * la[2] + t * lb[2]});
    }
    case ColorSpace::Diverging:
        return interpolateDiverging(a, b, t);
    }
    return lerp(a, b, t);
}

std::vector<ColorPoint> linearizeColors(ColorSpace space, const std::vector<ColorPoint>& points,
                                        double tolerance) {
    if (space == ColorSpace::Rgb || points.size() < 2) return points;
    std::vector<ColorPoint> out{points.front()};
    for (std::size_t i = 0; i + 1 < points.size(); ++i) {
        const ColorPoint& p = points[i];
        const ColorPoint& q = points[i + 1];
        const double width = q.s - p.s;
        if (!(width > 0.0)) {
            out.push_back(q); // two points at one s: a step, kept as authored
        } else if (space == ColorSpace::Step) {
            out.push_back({p.s, q.rgb}); // at p.s the earlier colour holds, just above it the next one
            out.push_back(q);
        } else {
            // The curve's own end values: a colour-space round trip (and the hue rule of the diverging
            // space) can leave them a little off the authored colours. At p.s the previous interval's
            // end holds; a difference to this interval's start becomes a step just above p.s.
            auto f = [&](double t) { return interpolateColor(space, p.rgb, q.rgb, t); };
            const Rgb start = f(0.0), end = f(1.0);
            if (maxChannelGap(start, out.back().rgb) > 0.0) out.push_back({p.s, start});
            std::vector<std::pair<double, Rgb>> inner;
            // The whole list shares one budget: 16,384 curved intervals of up to 4,095 points each would
            // otherwise make 67 million (29 s, 2 GB) before any table is built.
            const std::size_t used = out.size() + 2; // this interval's end and a possible final point
            bisect(f, 0.0, start, 1.0, end, tolerance, 0, inner,
                   used < kMaxLinearizedColorPoints ? kMaxLinearizedColorPoints - used : 0);
            for (const auto& [t, c] : inner)
                out.push_back({p.s + t * width, c});
            out.push_back({q.s, end});
        }
    }
    // Beyond the last point the authored colour holds.
    if (maxChannelGap(out.back().rgb, points.back().rgb) > 0.0) out.push_back(points.back());
    return out;
}

} // namespace volcl
