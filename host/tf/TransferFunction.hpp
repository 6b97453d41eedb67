// Transfer functions: canonical JSON, ParaView colour-map import, built-in presets, RGBA strips, exact sampling.
#pragma once

#include "cl/volcl_shared.h"

#include <array>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace volcl {

/// Extinction used for an imported opacity of exactly 1 (tau = -ln(1 - a) is infinite there).
inline constexpr double kMaxImportedExtinction = 1000.0;
/// Most points a transfer function file may state per list (canonical `color` / `extinction`, ParaView
/// `RGBPoints` / `Points`, a strip's pixels). Work downstream grows with the points (an exact 2D table of
/// N^2 entries integrates over every piece between s_f and s_b), so a small file claiming a million of
/// them (a 300-byte compressed strip) is refused before any work; colour maps have hundreds.
inline constexpr std::size_t kMaxTransferFunctionPoints = 16384;
/// Opacity per unit distance given to a ParaView colour map that has no opacity `Points` (the built-in
/// presets): ParaView's default ramp, linear in opacity from 0 at the bottom of its colour range to this
/// value at the top, as ParaView keeps its default opacity when a colour preset is applied.
inline constexpr double kColorOnlyTopOpacity = 1.0;

struct ColorPoint {
    double s;
    std::array<double, 3> rgb;
};
struct ExtinctionPoint {
    double s;
    double tau;
};
/// A factor in [0, 1] on the 1D extinction at gradient magnitude g (VTK's gradient opacity).
struct GradientOpacityPoint {
    double g;
    double factor;
};
/// Most widgets a 2D transfer function may hold: every sample of a gradient-classified ray visits each one.
inline constexpr std::size_t kMaxTfWidgets = 64;
enum class TfWidgetShape { Box, Gaussian, ParaViewBox };
/// The Gaussian of a ParaView 2D transfer-function box has this sigma, as a fraction of the box's width and
/// height on each axis (vtkPVTransferFunction2DBox: GaussianSigmaFactor 30 % of its 128-texel texture).
inline constexpr double kParaViewBoxSigma = 0.3;
/// One widget of a 2D transfer function over (value s, gradient magnitude g): it adds extinction
/// extinction(s, g) of colour rgb. A box adds tau on [value lo, hi] x [gradient lo, hi] (ends included), 0
/// elsewhere; a Gaussian tau * exp(-((s - cs) / sigma_s)^2 / 2 - ((g - cg) / sigma_g)^2 / 2). A ParaView box
/// (imported from a ParaView state) is ParaView's: inside its range an opacity
/// a = opacity * exp(-(u^2 + v^2) / 2), u and v the offsets from the box's centre over kParaViewBoxSigma of
/// its width and height, taken as opacity per unitDistance: tau = -ln(1 - a) / unitDistance.
struct TfWidget {
    TfWidgetShape shape = TfWidgetShape::Box;
    std::array<double, 2> valueRange{0.0, 0.0};    ///< box, ParaView box
    std::array<double, 2> gradientRange{0.0, 0.0}; ///< box, ParaView box
    std::array<double, 2> center{0.0, 0.0};        ///< Gaussian: (value, gradient magnitude)
    std::array<double, 2> sigma{1.0, 1.0};         ///< Gaussian: (value, gradient magnitude), > 0
    std::array<double, 3> rgb{1.0, 1.0, 1.0};
    double tau = 0.0;          ///< box, Gaussian
    double opacity = 0.0;      ///< ParaView box: the opacity at its centre, in [0, 1]
    double unitDistance = 1.0; ///< ParaView box: the world length its opacity holds over
    /// The extinction the widget adds at (s, g), in double; 0 when s or g is not finite (a sample beside a
    /// NaN voxel has no gradient).
    double extinction(double s, double g) const;
};

/// Piecewise-linear colour c(s) and extinction tau(s) in data units, constant beyond the end points.
/// Two points at the same s form a step: at s exactly the earlier point's value holds, above it the later.
/// Example:
/// ```
/// auto tf = volcl::TransferFunction::fromFile("tf.json");
/// double tau = tf.extinctionAt(80.0);
/// auto knots = tf.packKnots();   // upload for kernels; tf.sampleFloat(s) gives the kernel's exact value
/// ```
class TransferFunction {
public:
    std::array<double, 2> domain{0.0, 255.0};
    std::vector<ColorPoint> color;           ///< sorted by s (stable: steps keep their order)
    std::vector<ExtinctionPoint> extinction; ///< sorted by s, tau >= 0
    /// The points were authored on [0, 1] (a normalised preset): fittedTo() maps them onto the data range.
    bool normalized = false;
    /// Gradient terms (JSON keys `gradient_opacity` and `widgets`). Gradient magnitudes are in data value
    /// per world unit (per mm for medical volumes), never rescaled. The extinction of a sample of value s
    /// and gradient magnitude g is tau(s) * gradientOpacityAt(g) + sum of the widgets' tau_i * w_i(s, g),
    /// its colour the extinction-weighted mean of the terms' colours (classify()).
    std::vector<GradientOpacityPoint> gradientOpacity; ///< sorted by g, g >= 0, factor in [0, 1]
    std::vector<TfWidget> widgets;

    /// Canonical JSON, ParaView colour-map JSON (detected by keys), a ParaView state (.pvsm: its 2D transfer
    /// function, fromParaViewState()), a built-in preset named
    /// `preset:NAME` (see builtinPresetNames()), or a 1D RGBA strip image (.png/.exr; `stripDomain` gives
    /// its data range). `opacityUnitDistance` is the world length over which an imported opacity a holds
    /// (ParaView's scalar opacity unit distance): tau = -ln(1 - a) / unitDistance. Throws
    /// IoError/DataError with the file name on bad input.
    static TransferFunction fromFile(const std::filesystem::path& path,
                                     std::array<double, 2> stripDomain = {0.0, 255.0},
                                     double opacityUnitDistance = 1.0);
    static TransferFunction fromJson(std::string_view json, double opacityUnitDistance = 1.0);
    /// ParaView colour map: RGBPoints interpolated in its ColorSpace (RGB, HSV, Lab, Diverging, Step) as
    /// ParaView draws it (followed by RGB knots to 1e-4), opacity Points with midpoint and sharpness.
    static TransferFunction fromParaView(std::string_view json, double opacityUnitDistance = 1.0);
    /// The 2D transfer function of a ParaView state file (.pvsm): its boxes as ParaView boxes (colour and
    /// opacity come from the 2D function alone in ParaView's 2D mode), the opacity unit distance of the
    /// representation that uses it (else `opacityUnitDistance`). Refuses a state with no 2D function in use
    /// or several, and one whose second axis is another array instead of the gradient magnitude. `name`
    /// names the file in messages.
    static TransferFunction fromParaViewState(std::string_view xml, const std::string& name,
                                              double opacityUnitDistance = 1.0);
    /// A built-in preset (`cool-to-warm`, `viridis`, ...), normalised to [0, 1]. Throws UsageError naming
    /// the known presets.
    static TransferFunction builtinPreset(std::string_view name, double opacityUnitDistance = 1.0);
    static std::vector<std::string> builtinPresetNames();
    /// What a scene without a transfer function renders with, as ParaView's default volume rendering:
    /// colour a grey ramp from black at dataRange[0] to white at dataRange[1], opacity a linear ramp from 0
    /// to 1 over the same range per `opacityUnitDistance` of length (constant data: a unit range around it).
    static TransferFunction paraViewDefault(std::array<double, 2> dataRange, double opacityUnitDistance);
    /// The function a render uses for data over `dataRange`: the file or preset `spec` (read with
    /// `opacityUnitDistance`; a strip image spans the data range) fitted to the data range or to
    /// `explicitRange`; without a spec, paraViewDefault() over `explicitRange` or the data range. The one
    /// place the command line and the Python package take their defaults from.
    static TransferFunction forRender(const std::optional<std::filesystem::path>& spec,
                                      std::array<double, 2> dataRange, double opacityUnitDistance,
                                      std::optional<std::array<double, 2>> explicitRange = std::nullopt);
    /// Strip of `n` RGBA pixels spanning `domain`; alpha is opacity per unit length.
    static TransferFunction fromRgbaStrip(const std::vector<std::array<float, 4>>& pixels,
                                          std::array<double, 2> domain);
    std::string toJson() const; ///< canonical JSON

    /// The same function with every control point and the domain mapped linearly from `domain` onto
    /// `range` (lo < hi, finite). Extinction values are unchanged.
    TransferFunction rescaled(std::array<double, 2> range) const;
    /// What a render uses: `explicitRange` when given; else a normalised function spread over
    /// `dataRange` (whatever that range, [0, 1] included); else this function as authored.
    TransferFunction fittedTo(std::array<double, 2> dataRange,
                              std::optional<std::array<double, 2>> explicitRange = std::nullopt) const;

    /// Checks ordering, finiteness, tau >= 0, domain lo < hi, at least one point each, and the gradient
    /// terms (factors in [0, 1], widgets of non-zero width). Throws DataError.
    void validate() const;

    /// True when the classification reads the gradient magnitude (gradient_opacity or widgets).
    bool usesGradient() const noexcept { return !gradientOpacity.empty() || !widgets.empty(); }
    /// The gradient-opacity factor at g (1 without points); a g that is not finite takes the last point's.
    double gradientOpacityAt(double g) const;
    /// Exact (r, g, b, tau) of a sample of value s and gradient magnitude g (the references' classification).
    std::array<double, 4> classify(double s, double g) const;
    /// Records that follow the 1D knots in the kernels' knot buffer (cl/common/tf_lookup.h, tf_gradient()):
    /// gradientKnotCount knots of the gradient opacity (factor in channel 3), then one VolclTfWidget per
    /// widget in a knot's 48 bytes.
    std::vector<VolclTfKnot> packGradientRecords() const;
    /// Knots of the gradient opacity alone (empty without it): what packGradientRecords() starts with.
    std::vector<VolclTfKnot> packGradientOpacityKnots() const;

    /// Exact double-precision values (used by references).
    std::array<double, 3> colorAt(double s) const;
    double extinctionAt(double s) const; ///< (named apart from the `extinction` member)
    /// Sorted, de-duplicated s of every control point inside (and at) the domain.
    std::vector<double> breakpoints() const;
    double maxExtinction() const;
    double maxColor() const; ///< largest colour channel value

    /// Merged colour+extinction knots for kernels (see cl/common/tf_lookup.h).
    std::vector<VolclTfKnot> packKnots() const;
    /// Float evaluation identical, bit for bit, to tf_sample() in kernels: (r, g, b, tau).
    static std::array<float, 4> sampleFloat(const std::vector<VolclTfKnot>& knots, float s);

private:
    void validateGradientTerms() const;
};

} // namespace volcl
