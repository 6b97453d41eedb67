// Colour interpolation between two transfer-function colours in RGB, HSV, CIELAB, diverging Msh or step.
#pragma once

#include <array>
#include <cstddef>
#include <string_view>
#include <vector>

namespace volcl {

struct ColorPoint;

/// How colour is interpolated between two control points, as ParaView's colour maps name them.
enum class ColorSpace { Rgb, Hsv, Lab, Diverging, Step };

/// "RGB", "HSV", "Lab", "Diverging", "Step" (case-insensitive); throws DataError for anything else.
ColorSpace parseColorSpace(std::string_view name);
std::string_view colorSpaceName(ColorSpace space);

using Rgb = std::array<double, 3>;

/// sRGB (display-encoded, [0, 1]) to CIELAB (D65 white, 2 degree observer) and back. The way back clips
/// an out-of-gamut colour by scaling the largest channel to 1 and clamping negative channels to 0.
std::array<double, 3> rgbToLab(const Rgb& rgb);
Rgb labToRgb(const std::array<double, 3>& lab);
/// HSV with hue in [0, 1).
std::array<double, 3> rgbToHsv(const Rgb& rgb);
Rgb hsvToRgb(const std::array<double, 3>& hsv);

/// Colour a fraction `t` in [0, 1] of the way from `a` to `b` in `space`. Diverging is Moreland's
/// polar-CIELAB (Msh) interpolation, which passes through a neutral white between two distinct
/// saturated colours; HSV takes the shorter way round the hue circle; Step holds `b` for t > 0.
Rgb interpolateColor(ColorSpace space, const Rgb& a, const Rgb& b, double t);

/// Most points linearizeColors() may return: four per point a transfer function file may state.
inline constexpr std::size_t kMaxLinearizedColorPoints = 65536;

/// Piecewise-linear RGB points that follow `space`'s interpolation between consecutive points of
/// `points` to within `tolerance` per channel, ParaView's way: at an input point the interval below it
/// ends with its own curve value (a colour-space round trip can move it slightly off the authored colour;
/// the diverging hue rule sometimes more), the interval above starts with its own (a step when they
/// differ), and beyond the ends the authored end colours hold. Two input points at one s stay a step.
/// RGB returns the input unchanged. More than kMaxLinearizedColorPoints points is a DataError, raised
/// while bisecting (the work stays proportional to the budget).
std::vector<ColorPoint> linearizeColors(ColorSpace space, const std::vector<ColorPoint>& points,
                                        double tolerance = 1e-4);

} // namespace volcl
