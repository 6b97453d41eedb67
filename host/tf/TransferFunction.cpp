// Transfer functions: canonical/ParaView JSON and strip import, validation, exact sampling and kernel knots.
#include "host/tf/TransferFunction.hpp"

#include "core/Error.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/BuiltinPresets.hpp"
#include "host/tf/ColorSpaces.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

namespace volcl {
namespace {

using nlohmann::json;

constexpr double kFloatMax = static_cast<double>(std::numeric_limits<float>::max());

std::string describe(double v) {
    std::ostringstream os;
    os.precision(17);
    os << v;
    return os.str();
}

/// Pieces of ParaView's default opacity ramp (0 to 1, linear in opacity): tau between the samples is linear,
/// within 2e-4 of -ln(1 - a) for a <= 0.9 (the interpolation error is h^2 / 8 / (1 - a)^2).
constexpr int kOpacityRampSamples = 256;

/// tau for an opacity per `unitDistance` of length; a = 1 has no finite answer and maps to
/// kMaxImportedExtinction (per unit distance). `where()` names the point, for the message only.
template <class Where> double opacityToExtinction(double a, Where where, double unitDistance = 1.0) {
    if (!std::isfinite(a) || a < 0.0 || a > 1.0)
        throw DataError(where() + ": opacity " + describe(a) + " is outside [0, 1]");
    if (a >= 1.0) return kMaxImportedExtinction / unitDistance;
    return std::min(-std::log1p(-a), kMaxImportedExtinction) / unitDistance;
}

void checkUnitDistance(double d) {
    if (!(std::isfinite(d) && d > 0.0))
        throw UsageError("opacity unit distance " + describe(d) + " must be finite and > 0");
}

/// The points span exactly [0, 1]: a normalised preset.
bool spansUnitRange(double lo, double hi) {
    return lo == 0.0 && hi == 1.0;
}

double number(const json& v, const std::string& where) {
    if (!v.is_number()) throw DataError(where + ": expected a number, got " + std::string(v.type_name()));
    return v.get<double>();
}

// Refuses a list of more than kMaxTransferFunctionPoints before it is read point by point.
void checkPointCount(std::size_t points, const std::string& what) {
    if (points > kMaxTransferFunctionPoints)
        throw DataError(what + " has " + std::to_string(points) + " points, more than the " +
                        std::to_string(kMaxTransferFunctionPoints) + " a transfer function may have");
}

json parseJson(std::string_view text) {
    try {
        return json::parse(text.begin(), text.end());
    } catch (const json::exception& e) {
        // parse_error for bad syntax, out_of_range for numbers such as 1e400 that no double holds.
        throw DataError(std::string("transfer function: invalid JSON (") + e.what() + ")");
    }
}

/// Left value (what holds at s itself) of a piecewise-linear list; `get` reads a point's value.
template <class P, class Get> auto valueAt(const std::vector<P>& pts, double s, Get get) {
    if (s <= pts.front().s) return get(pts.front());
    if (s > pts.back().s) return get(pts.back());
    // Last point strictly below s; the next one is at or above s and strictly to the right of it.
    auto it = std::lower_bound(pts.begin(), pts.end(), s, [](const P& p, double x) { return p.s < x; });
    const P& b = *it;
    const P& a = *(it - 1);
    const double t = (s - a.s) / (b.s - a.s);
    auto va = get(a), vb = get(b);
    decltype(va) out{};
    for (std::size_t c = 0; c < va.size(); ++c)
        out[c] = va[c] + t * (vb[c] - va[c]);
    return out;
}

/// Right limit (value just above s): the last point at s when one lies there, else the interpolated value.
template <class P, class Get> auto rightValueAt(const std::vector<P>& pts, double s, Get get) {
    auto it = std::upper_bound(pts.begin(), pts.end(), s, [](double x, const P& p) { return x < p.s; });
    if (it != pts.begin() && (it - 1)->s == s) return get(*(it - 1));
    return valueAt(pts, s, get);
}

std::array<double, 4> leftRgbt(const TransferFunction& tf, double s) {
    auto c = tf.colorAt(s);
    return {c[0], c[1], c[2], tf.extinctionAt(s)};
}
std::array<double, 4> rightRgbt(const TransferFunction& tf, double s) {
    auto c = rightValueAt(tf.color, s, [](const ColorPoint& p) { return p.rgb; });
    auto t =
        rightValueAt(tf.extinction, s, [](const ExtinctionPoint& p) { return std::array<double, 1>{p.tau}; });
    return {c[0], c[1], c[2], t[0]};
}

/// Finite, and finite once stored as float (what kernels read).
bool finiteInFloat(double v) {
    return std::isfinite(v) && std::abs(v) <= kFloatMax;
}

float toFloatSaturated(double v) {
    return static_cast<float>(std::clamp(v, -kFloatMax, kFloatMax));
}

// ParaView's vtkPiecewiseFunction interpolation between two nodes (midpoint, sharpness of the first node).
double paraViewOpacity(double x1, double y1, double x2, double y2, double midpoint, double sharpness,
                       double x) {
    midpoint = std::clamp(midpoint, 0.00001, 0.99999);
    double s = (x - x1) / (x2 - x1);
    s = s < midpoint ? 0.5 * s / midpoint : 0.5 + 0.5 * (s - midpoint) / (1.0 - midpoint);
    if (sharpness > 0.99) return s < 0.5 ? y1 : y2;
    if (sharpness < 0.01) return (1.0 - s) * y1 + s * y2;
    if (s < 0.5)
        s = 0.5 * std::pow(s * 2.0, 1.0 + 10.0 * sharpness);
    else if (s > 0.5)
        s = 1.0 - 0.5 * std::pow((1.0 - s) * 2.0, 1.0 + 10.0 * sharpness);
    const double ss = s * s, sss = ss * s;
    const double h1 = 2 * sss - 3 * ss + 1, h2 = -2 * sss + 3 * ss, h3 = sss - 2 * ss + s, h4 = sss - ss;
    const double t = (1.0 - sharpness) * (y2 - y1);
    const double v = h1 * y1 + h2 * y2 + h3 * t + h4 * t;
    return std::clamp(v, std::min(y1, y2), std::max(y1, y2));
}

// Sub-intervals used to follow a curved (hermite) ParaView opacity segment with linear pieces.
constexpr int kParaViewCurveSamples = 64;

std::array<double, 2> pairOf(const json& j, const char* key, const std::string& where) {
    if (!j.contains(key) || !j[key].is_array() || j[key].size() != 2)
        throw DataError(where + ": '" + key + "' must be [a, b]");
    return {number(j[key][0], where + ": " + key), number(j[key][1], where + ": " + key)};
}

/// The gradient terms of a canonical TF: `gradient_opacity` [[g, factor], ...] and `widgets` (box:
/// value, gradient ranges; gaussian: center, sigma; both color [r, g, b] and extinction).
void readGradientTerms(const json& j, TransferFunction& tf) {
    if (j.contains("gradient_opacity")) {
        const auto& go = j["gradient_opacity"];
        if (!go.is_array())
            throw DataError("transfer function: 'gradient_opacity' must be an array of [g, factor]");
        checkPointCount(go.size(), "transfer function: 'gradient_opacity'");
        std::size_t i = 0;
        for (const auto& p : go) {
            const std::string where = "transfer function: gradient_opacity[" + std::to_string(i++) + "]";
            if (!p.is_array() || p.size() != 2) throw DataError(where + ": expected [g, factor]");
            tf.gradientOpacity.push_back({number(p[0], where), number(p[1], where)});
        }
        if (tf.gradientOpacity.empty())
            throw DataError("transfer function: 'gradient_opacity' has no points");
    }
    if (j.contains("widgets")) {
        const auto& ws = j["widgets"];
        if (!ws.is_array()) throw DataError("transfer function: 'widgets' must be an array of objects");
        if (ws.size() > kMaxTfWidgets)
            throw DataError("transfer function: " + std::to_string(ws.size()) + " widgets, more than the " +
                            std::to_string(kMaxTfWidgets) + " a transfer function may have");
        std::size_t i = 0;
        for (const auto& w : ws) {
            const std::string where = "transfer function: widgets[" + std::to_string(i++) + "]";
            if (!w.is_object()) throw DataError(where + ": expected an object");
            TfWidget out;
            const std::string type =
                w.contains("type") && w["type"].is_string() ? w["type"].get<std::string>() : "";
            const bool paraView = type == "paraview_box";
            const bool box = type == "box" || paraView;
            if (!box && type != "gaussian")
                throw DataError(where + ": 'type' must be \"box\", \"gaussian\" or \"paraview_box\"");
            for (const auto& [key, value] : w.items()) {
                (void)value;
                const bool known =
                    key == "type" || key == "color" || key == "name" ||
                    (paraView ? key == "opacity" || key == "unit_distance" : key == "extinction") ||
                    (box ? key == "value" || key == "gradient" : key == "center" || key == "sigma");
                if (!known)
                    throw DataError(where + ": unknown key '" + key + "' (a " + type + " takes type, " +
                                    (box ? "value, gradient" : "center, sigma") + ", color, " +
                                    (paraView ? "opacity, unit_distance" : "extinction") + ", name)");
            }
            if (box) {
                out.shape = paraView ? TfWidgetShape::ParaViewBox : TfWidgetShape::Box;
                out.valueRange = pairOf(w, "value", where);
                out.gradientRange = pairOf(w, "gradient", where);
            } else {
                out.shape = TfWidgetShape::Gaussian;
                out.center = pairOf(w, "center", where);
                out.sigma = pairOf(w, "sigma", where);
            }
            if (!w.contains("color") || !w["color"].is_array() || w["color"].size() != 3)
                throw DataError(where + ": 'color' must be [r, g, b]");
            for (std::size_t c = 0; c < 3; ++c)
                out.rgb[c] = number(w["color"][c], where + ": color");
            if (paraView) {
                if (!w.contains("opacity")) throw DataError(where + ": missing 'opacity'");
                out.opacity = number(w["opacity"], where + ": opacity");
                if (w.contains("unit_distance"))
                    out.unitDistance = number(w["unit_distance"], where + ": unit_distance");
            } else {
                if (!w.contains("extinction")) throw DataError(where + ": missing 'extinction'");
                out.tau = number(w["extinction"], where + ": extinction");
            }
            tf.widgets.push_back(out);
        }
    }
}
} // namespace

TransferFunction TransferFunction::fromJson(std::string_view text, double opacityUnitDistance) {
    json j = parseJson(text);
    const bool paraView =
        (j.is_array() && !j.empty() && j.front().is_object() && j.front().contains("RGBPoints")) ||
        (j.is_object() && (j.contains("RGBPoints") || j.contains("Points")));
    if (paraView) return fromParaView(text, opacityUnitDistance);
    if (!j.is_object())
        throw DataError("transfer function: expected a JSON object with 'color' and 'extinction'");

    TransferFunction tf;
    for (const auto& [key, value] : j.items()) {
        if (key != "domain" && key != "color" && key != "extinction" && key != "name" &&
            key != "gradient_opacity" && key != "widgets")
            throw DataError("transfer function: unknown key '" + key +
                            "' (expected domain, color, extinction, gradient_opacity, widgets, name)");
        (void)value;
    }
    readGradientTerms(j, tf);
    // A TF of widgets alone: the value axis adds nothing (black, tau 0) over the domain.
    if (!tf.widgets.empty() && !j.contains("color") && !j.contains("extinction")) {
        if (!j.contains("domain"))
            throw DataError("transfer function: widgets without 'color' and 'extinction' need a 'domain'");
        const auto& d = j["domain"];
        if (!d.is_array() || d.size() != 2) throw DataError("transfer function: 'domain' must be [lo, hi]");
        const double lo = number(d[0], "transfer function: domain"),
                     hi = number(d[1], "transfer function: domain");
        j["color"] = json::array({json::array({lo, 0.0, 0.0, 0.0}), json::array({hi, 0.0, 0.0, 0.0})});
        j["extinction"] = json::array({json::array({lo, 0.0}), json::array({hi, 0.0})});
    }
    for (const char* key : {"color", "extinction"})
        if (!j.contains(key) || !j[key].is_array())
            throw DataError(std::string("transfer function: missing array '") + key + "'");

    checkPointCount(j["color"].size(), "transfer function: 'color'");
    checkPointCount(j["extinction"].size(), "transfer function: 'extinction'");
    std::size_t i = 0;
    for (const auto& p : j["color"]) {
        const std::string where = "transfer function: color[" + std::to_string(i++) + "]";
        if (!p.is_array() || p.size() != 4) throw DataError(where + ": expected [s, r, g, b]");
        tf.color.push_back(
            {number(p[0], where), {number(p[1], where), number(p[2], where), number(p[3], where)}});
    }
    i = 0;
    for (const auto& p : j["extinction"]) {
        const std::string where = "transfer function: extinction[" + std::to_string(i++) + "]";
        if (!p.is_array() || p.size() != 2) throw DataError(where + ": expected [s, tau]");
        tf.extinction.push_back({number(p[0], where), number(p[1], where)});
    }
    if (j.contains("domain")) {
        const auto& d = j["domain"];
        if (!d.is_array() || d.size() != 2) throw DataError("transfer function: 'domain' must be [lo, hi]");
        tf.domain = {number(d[0], "transfer function: domain"), number(d[1], "transfer function: domain")};
    } else if (!tf.color.empty() && !tf.extinction.empty()) {
        tf.domain = {std::min(tf.color.front().s, tf.extinction.front().s),
                     std::max(tf.color.back().s, tf.extinction.back().s)};
    }
    // Gradient magnitudes are absolute (data value per world unit): such a TF is never refitted silently.
    tf.normalized = spansUnitRange(tf.domain[0], tf.domain[1]) && !tf.usesGradient();
    tf.validate();
    return tf;
}

TransferFunction TransferFunction::fromParaView(std::string_view text, double opacityUnitDistance) {
    checkUnitDistance(opacityUnitDistance);
    json root = parseJson(text);
    const json* j = &root;
    if (root.is_array()) {
        if (root.empty() || !root.front().is_object())
            throw DataError("ParaView colour map: expected an array holding one colour-map object");
        j = &root.front();
    }
    if (!j->is_object()) throw DataError("ParaView colour map: expected a JSON object");

    TransferFunction tf;
    ColorSpace space = ColorSpace::Rgb; // ParaView's default when the key is absent
    if (j->contains("ColorSpace")) {
        if (!(*j)["ColorSpace"].is_string())
            throw DataError("ParaView colour map: 'ColorSpace' must be a string");
        try {
            space = parseColorSpace((*j)["ColorSpace"].get<std::string>());
        } catch (const DataError& e) {
            throw DataError(std::string("ParaView colour map: ") + e.what());
        }
    }
    if (j->contains("RGBPoints")) {
        const json& p = (*j)["RGBPoints"];
        if (!p.is_array() || p.empty() || p.size() % 4 != 0)
            throw DataError("ParaView colour map: 'RGBPoints' must hold groups of 4 numbers (x, r, g, b)");
        checkPointCount(p.size() / 4, "ParaView colour map: 'RGBPoints'");
        for (std::size_t i = 0; i < p.size(); i += 4) {
            const std::string where = "ParaView colour map: RGBPoints[" + std::to_string(i) + "]";
            tf.color.push_back({number(p[i], where),
                                {number(p[i + 1], where), number(p[i + 2], where), number(p[i + 3], where)}});
        }
    }
    struct OpacityNode {
        double x, a, midpoint, sharpness;
    };
    std::vector<OpacityNode> nodes;
    if (j->contains("Points")) {
        const json& p = (*j)["Points"];
        if (!p.is_array() || p.empty() || p.size() % 4 != 0)
            throw DataError(
                "ParaView colour map: 'Points' must hold groups of 4 numbers (x, a, midpoint, sharpness)");
        checkPointCount(p.size() / 4, "ParaView colour map: 'Points'");
        for (std::size_t i = 0; i < p.size(); i += 4) {
            const std::string where = "ParaView colour map: Points[" + std::to_string(i) + "]";
            nodes.push_back({number(p[i], where), number(p[i + 1], where), number(p[i + 2], where),
                             number(p[i + 3], where)});
            if (!(nodes.back().a >= 0.0 && nodes.back().a <= 1.0))
                throw DataError(where + ": opacity " + describe(nodes.back().a) + " is outside [0, 1]");
        }
    }
    if (tf.color.empty()) throw DataError("ParaView colour map: no 'RGBPoints'");
    for (std::size_t i = 1; i < tf.color.size(); ++i)
        if (!(tf.color[i].s >= tf.color[i - 1].s))
            throw DataError("ParaView colour map: 'RGBPoints' are not sorted by x at point " +
                            std::to_string(i));
    if (nodes.empty()) {
        // A colour-only map keeps ParaView's default opacity: a ramp over the colour range, linear in opacity
        // (sampled as paraViewDefault() does, so tau follows -ln(1 - a)).
        const double lo = tf.color.front().s, hi = tf.color.back().s;
        for (int k = 0; k <= kOpacityRampSamples; ++k) {
            const double t = double(k) / kOpacityRampSamples;
            nodes.push_back(
                {k == kOpacityRampSamples ? hi : lo + (hi - lo) * t, t * kColorOnlyTopOpacity, 0.5, 0.0});
        }
    }
    for (std::size_t i = 1; i < nodes.size(); ++i)
        if (!(nodes[i].x >= nodes[i - 1].x))
            throw DataError("ParaView colour map: 'Points' are not sorted by x at node " + std::to_string(i));

    auto push = [&](double x, double a) {
        tf.extinction.push_back(
            {x, opacityToExtinction(
                    a, [] { return std::string("ParaView colour map"); }, opacityUnitDistance)});
    };
    push(nodes.front().x, nodes.front().a);
    for (std::size_t i = 0; i + 1 < nodes.size(); ++i) {
        const OpacityNode& n = nodes[i];
        const OpacityNode& m = nodes[i + 1];
        const double width = m.x - n.x;
        const bool linear = n.sharpness < 0.01;
        if (width > 0.0 && n.sharpness > 0.99) {
            // Piecewise constant: a step where the remapped position crosses one half (at the midpoint).
            const double xm = n.x + std::clamp(n.midpoint, 0.00001, 0.99999) * width;
            push(xm, n.a);
            push(xm, m.a);
        } else if (width > 0.0 && linear && std::abs(n.midpoint - 0.5) > 1e-12) {
            push(n.x + std::clamp(n.midpoint, 0.00001, 0.99999) * width, 0.5 * (n.a + m.a));
        } else if (width > 0.0 && !linear) {
            for (int k = 1; k < kParaViewCurveSamples; ++k) {
                const double x = n.x + width * k / kParaViewCurveSamples;
                push(x, paraViewOpacity(n.x, n.a, m.x, m.a, n.midpoint, n.sharpness, x));
            }
        }
        push(m.x, m.a);
    }
    tf.domain = {std::min(tf.color.front().s, nodes.front().x), std::max(tf.color.back().s, nodes.back().x)};
    if (!(tf.domain[0] < tf.domain[1]))
        throw DataError("ParaView colour map: all points sit at one value " + describe(tf.domain[0]) +
                        ", so it spans no data range");
    tf.normalized = spansUnitRange(tf.domain[0], tf.domain[1]);
    tf.validate(); // finiteness before the colour-space arithmetic
    tf.color = linearizeColors(space, tf.color);
    tf.validate();
    return tf;
}

TransferFunction TransferFunction::builtinPreset(std::string_view name, double opacityUnitDistance) {
    const std::string_view text = builtinPresetJson(name);
    if (text.empty()) {
        std::string list;
        for (const auto& n : builtinPresetNames())
            list += (list.empty() ? "" : ", ") + n;
        throw UsageError("unknown preset '" + std::string(name) + "' (built-in presets: " + list + ")");
    }
    return fromParaView(text, opacityUnitDistance);
}

std::vector<std::string> TransferFunction::builtinPresetNames() {
    std::vector<std::string> out;
    for (std::string_view n : volcl::builtinPresetNames())
        out.emplace_back(n);
    return out;
}

TransferFunction TransferFunction::rescaled(std::array<double, 2> range) const {
    if (!(std::isfinite(range[0]) && std::isfinite(range[1]) && range[0] < range[1]))
        throw UsageError("transfer function range [" + describe(range[0]) + ", " + describe(range[1]) +
                         "] must be finite with lo < hi");
    const double k = (range[1] - range[0]) / (domain[1] - domain[0]);
    auto map = [&](double s) { return range[0] + (s - domain[0]) * k; };
    TransferFunction out = *this;
    for (auto& p : out.color)
        p.s = map(p.s);
    for (auto& p : out.extinction)
        p.s = map(p.s);
    for (auto& w : out.widgets) {
        w.valueRange = {map(w.valueRange[0]), map(w.valueRange[1])};
        w.center[0] = map(w.center[0]);
        w.sigma[0] *= k;
    }
    out.domain = range;
    out.normalized = false;
    out.validate();
    return out;
}

TransferFunction TransferFunction::fittedTo(std::array<double, 2> dataRange,
                                            std::optional<std::array<double, 2>> explicitRange) const {
    if (explicitRange) return rescaled(*explicitRange);
    // Whatever the data range, [0, 1] data included: data in 1e-6..1e-4 must not see the map's bottom only.
    if (normalized) {
        // Constant data still needs a range with lo < hi: centre the colour map's middle on it.
        if (!(dataRange[0] < dataRange[1])) dataRange = {dataRange[0] - 0.5, dataRange[0] + 0.5};
        return rescaled(dataRange);
    }
    return *this;
}

TransferFunction TransferFunction::forRender(const std::optional<std::filesystem::path>& spec,
                                             std::array<double, 2> dataRange, double opacityUnitDistance,
                                             std::optional<std::array<double, 2>> explicitRange) {
    if (!spec) return paraViewDefault(explicitRange ? *explicitRange : dataRange, opacityUnitDistance);
    const std::array<double, 2> stripDomain{dataRange[0],
                                            dataRange[1] > dataRange[0] ? dataRange[1] : dataRange[0] + 1.0};
    return fromFile(*spec, stripDomain, opacityUnitDistance).fittedTo(dataRange, explicitRange);
}

TransferFunction TransferFunction::paraViewDefault(std::array<double, 2> dataRange,
                                                   double opacityUnitDistance) {
    checkUnitDistance(opacityUnitDistance);
    if (!(std::isfinite(dataRange[0]) && std::isfinite(dataRange[1]) && dataRange[0] <= dataRange[1]))
        throw UsageError("default transfer function: data range [" + describe(dataRange[0]) + ", " +
                         describe(dataRange[1]) + "] is not finite");
    if (!(dataRange[0] < dataRange[1])) dataRange = {dataRange[0] - 0.5, dataRange[0] + 0.5};
    const auto [lo, hi] = dataRange;
    TransferFunction tf;
    tf.domain = dataRange;
    tf.color = {{lo, {0.0, 0.0, 0.0}}, {hi, {1.0, 1.0, 1.0}}};
    for (int k = 0; k <= kOpacityRampSamples; ++k) {
        const double a = double(k) / kOpacityRampSamples;
        const double s = k == kOpacityRampSamples ? hi : lo + (hi - lo) * a;
        tf.extinction.push_back(
            {s, opacityToExtinction(
                    a, [] { return std::string("default transfer function"); }, opacityUnitDistance)});
    }
    tf.validate();
    return tf;
}

TransferFunction TransferFunction::fromRgbaStrip(const std::vector<std::array<float, 4>>& pixels,
                                                 std::array<double, 2> domain) {
    if (pixels.empty()) throw DataError("RGBA strip: no pixels");
    checkPointCount(pixels.size(), "RGBA strip");
    if (!(std::isfinite(domain[0]) && std::isfinite(domain[1]) && domain[0] < domain[1]))
        throw DataError("RGBA strip: domain [" + describe(domain[0]) + ", " + describe(domain[1]) +
                        "] must be finite with lo < hi");
    TransferFunction tf;
    tf.domain = domain;
    const std::size_t n = pixels.size();
    for (std::size_t i = 0; i < n; ++i) {
        const double s = n == 1 ? domain[0] : domain[0] + (domain[1] - domain[0]) * double(i) / double(n - 1);
        const auto& p = pixels[i];
        auto where = [i] { return "RGBA strip pixel " + std::to_string(i); };
        for (float v : p)
            if (!std::isfinite(v)) throw DataError(where() + ": value is not finite");
        tf.color.push_back({s, {p[0], p[1], p[2]}});
        tf.extinction.push_back({s, opacityToExtinction(p[3], where)});
    }
    tf.validate();
    return tf;
}

TransferFunction TransferFunction::fromFile(const std::filesystem::path& path,
                                            std::array<double, 2> stripDomain, double opacityUnitDistance) {
    constexpr std::string_view kPresetPrefix = "preset:";
    if (const std::string p = path.string(); p.rfind(kPresetPrefix, 0) == 0)
        return builtinPreset(std::string_view(p).substr(kPresetPrefix.size()), opacityUnitDistance);
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    const std::string name = path.string();
    if (!std::filesystem::is_regular_file(path)) throw IoError(name + ": transfer function file not found");
    try {
        if (ext == ".pvsm") {
            // Bounded before it is read: ParaView states are kilobytes to a few megabytes.
            constexpr std::uintmax_t kMaxStateBytes = std::uintmax_t(64) << 20;
            if (std::filesystem::file_size(path) > kMaxStateBytes)
                throw IoError(name + ": ParaView state of " +
                              std::to_string(std::filesystem::file_size(path)) +
                              " bytes, more than the 64 MiB a state file may have");
            std::ifstream in(path, std::ios::binary);
            std::ostringstream text;
            text << in.rdbuf();
            if (!in.good() && !in.eof()) throw IoError(name + ": cannot read ParaView state");
            return fromParaViewState(text.str(), name, opacityUnitDistance);
        }
        if (ext == ".json") {
            std::ifstream in(path, std::ios::binary);
            std::ostringstream text;
            text << in.rdbuf();
            if (!in.good() && !in.eof()) throw IoError(name + ": cannot read transfer function");
            return fromJson(text.str(), opacityUnitDistance);
        }
        if (ext == ".png" || ext == ".exr" || ext == ".tif" || ext == ".tiff") {
            // What reading the widest strip takes: its RGBA float pixels as stored and as floats, and
            // OpenEXR's four chunk buffers of 32 lines (PIZ, B44, DWAA; ZIP has 16): 34 MB. A forged data
            // window is refused before allocation, a strip wider than kMaxTransferFunctionPoints after it.
            constexpr std::size_t kMaxStripBytes = kMaxTransferFunctionPoints * (16 + 16 + 4 * 32 * 16);
            ImageBuffer img = readImage(path, kMaxStripBytes);
            if (img.height != 1)
                throw DataError("RGBA strip must be 1 pixel high, this one is " + std::to_string(img.width) +
                                "x" + std::to_string(img.height));
            if (img.channelCount() < 4)
                throw DataError("RGBA strip needs 4 channels (R, G, B, A), this one has " +
                                std::to_string(img.channelCount()));
            checkPointCount(std::size_t(img.width), "RGBA strip");
            std::vector<std::array<float, 4>> px(static_cast<std::size_t>(img.width));
            for (int x = 0; x < img.width; ++x)
                for (int c = 0; c < 4; ++c)
                    px[std::size_t(x)][std::size_t(c)] = img.at(x, 0, c);
            return fromRgbaStrip(px, stripDomain);
        }
    } catch (const DataError& e) {
        throw DataError(name + ": " + e.what());
    }
    throw IoError(name + ": unknown transfer function format '" + ext +
                  "' (expected .json, .pvsm, .png or .exr)");
}

std::string TransferFunction::toJson() const {
    json j;
    j["domain"] = {domain[0], domain[1]};
    j["color"] = json::array();
    for (const auto& p : color)
        j["color"].push_back({p.s, p.rgb[0], p.rgb[1], p.rgb[2]});
    j["extinction"] = json::array();
    for (const auto& p : extinction)
        j["extinction"].push_back({p.s, p.tau});
    if (!gradientOpacity.empty()) {
        j["gradient_opacity"] = json::array();
        for (const auto& p : gradientOpacity)
            j["gradient_opacity"].push_back({p.g, p.factor});
    }
    if (!widgets.empty()) {
        j["widgets"] = json::array();
        for (const auto& w : widgets) {
            json o;
            if (w.shape == TfWidgetShape::Gaussian) {
                o["type"] = "gaussian";
                o["center"] = {w.center[0], w.center[1]};
                o["sigma"] = {w.sigma[0], w.sigma[1]};
            } else {
                o["type"] = w.shape == TfWidgetShape::Box ? "box" : "paraview_box";
                o["value"] = {w.valueRange[0], w.valueRange[1]};
                o["gradient"] = {w.gradientRange[0], w.gradientRange[1]};
            }
            o["color"] = {w.rgb[0], w.rgb[1], w.rgb[2]};
            if (w.shape == TfWidgetShape::ParaViewBox) {
                o["opacity"] = w.opacity;
                o["unit_distance"] = w.unitDistance;
            } else {
                o["extinction"] = w.tau;
            }
            j["widgets"].push_back(o);
        }
    }
    return j.dump(2);
}

void TransferFunction::validate() const {
    if (!(finiteInFloat(domain[0]) && finiteInFloat(domain[1])))
        throw DataError("transfer function: domain is not finite");
    if (!(domain[0] < domain[1]))
        throw DataError("transfer function: domain [" + describe(domain[0]) + ", " + describe(domain[1]) +
                        "] needs lo < hi");
    if (color.empty()) throw DataError("transfer function: 'color' has no points");
    if (extinction.empty()) throw DataError("transfer function: 'extinction' has no points");
    // The point's name is built only for a message: per point it cost more than the checks.
    for (std::size_t i = 0; i < color.size(); ++i) {
        const auto& p = color[i];
        auto where = [i] { return "transfer function: color[" + std::to_string(i) + "]"; };
        if (!finiteInFloat(p.s)) throw DataError(where() + ": s is not a finite float");
        for (double c : p.rgb)
            if (!finiteInFloat(c))
                throw DataError(where() + ": colour " + describe(c) + " is not a finite float");
        if (i > 0 && p.s < color[i - 1].s)
            throw DataError(where() + ": s = " + describe(p.s) + " is below the previous point's " +
                            describe(color[i - 1].s) + " (points must be sorted)");
    }
    for (std::size_t i = 0; i < extinction.size(); ++i) {
        const auto& p = extinction[i];
        auto where = [i] { return "transfer function: extinction[" + std::to_string(i) + "]"; };
        if (!finiteInFloat(p.s)) throw DataError(where() + ": s is not a finite float");
        if (!finiteInFloat(p.tau))
            throw DataError(where() + ": tau " + describe(p.tau) + " is not a finite float");
        if (p.tau < 0.0) throw DataError(where() + ": tau " + describe(p.tau) + " is negative");
        if (i > 0 && p.s < extinction[i - 1].s)
            throw DataError(where() + ": s = " + describe(p.s) + " is below the previous point's " +
                            describe(extinction[i - 1].s) + " (points must be sorted)");
    }
    validateGradientTerms();
}

void TransferFunction::validateGradientTerms() const {
    for (std::size_t i = 0; i < gradientOpacity.size(); ++i) {
        const auto& p = gradientOpacity[i];
        // The point's name is built only for a message (as in validate()).
        auto where = [i] { return "transfer function: gradient_opacity[" + std::to_string(i) + "]"; };
        if (!finiteInFloat(p.g) || p.g < 0.0)
            throw DataError(where() + ": gradient magnitude " + describe(p.g) + " must be finite and >= 0");
        if (!(p.factor >= 0.0 && p.factor <= 1.0))
            throw DataError(where() + ": factor " + describe(p.factor) + " is outside [0, 1]");
        if (i > 0 && p.g < gradientOpacity[i - 1].g)
            throw DataError(where() + ": g = " + describe(p.g) + " is below the previous point's " +
                            describe(gradientOpacity[i - 1].g) + " (points must be sorted)");
    }
    if (widgets.size() > kMaxTfWidgets)
        throw DataError("transfer function: " + std::to_string(widgets.size()) + " widgets, more than " +
                        std::to_string(kMaxTfWidgets));
    for (std::size_t i = 0; i < widgets.size(); ++i) {
        const TfWidget& w = widgets[i];
        const std::string where = "transfer function: widgets[" + std::to_string(i) + "]";
        for (double c : w.rgb)
            if (!finiteInFloat(c) || c < 0.0)
                throw DataError(where + ": colour " + describe(c) + " must be finite and >= 0");
        if (!finiteInFloat(w.tau) || w.tau < 0.0)
            throw DataError(where + ": extinction " + describe(w.tau) + " must be finite and >= 0");
        if (w.shape == TfWidgetShape::ParaViewBox) {
            if (!(w.opacity >= 0.0 && w.opacity <= 1.0))
                throw DataError(where + ": opacity " + describe(w.opacity) + " is outside [0, 1]");
            // 1 / unitDistance must be a finite float: the kernel multiplies by it.
            if (!(finiteInFloat(w.unitDistance) && w.unitDistance > 0.0 &&
                  std::isfinite(static_cast<float>(1.0 / w.unitDistance))))
                throw DataError(where + ": unit distance " + describe(w.unitDistance) +
                                " must be finite and > 0");
        }
        if (w.shape != TfWidgetShape::Gaussian) {
            for (const auto& [r, axis] :
                 {std::pair{w.valueRange, "value"}, std::pair{w.gradientRange, "gradient"}}) {
                if (!finiteInFloat(r[0]) || !finiteInFloat(r[1]))
                    throw DataError(where + ": " + axis + " range is not finite");
                // A box of zero width covers no area: it would classify nothing (or, in float, a sliver).
                if (!(r[0] < r[1]))
                    throw DataError(where + ": " + axis + " range [" + describe(r[0]) + ", " +
                                    describe(r[1]) + "] has zero width (needs lo < hi)");
            }
            if (w.gradientRange[1] <= 0.0)
                throw DataError(where + ": gradient range ends at " + describe(w.gradientRange[1]) +
                                ", below every gradient magnitude");
        } else {
            if (!finiteInFloat(w.center[0]) || !finiteInFloat(w.center[1]))
                throw DataError(where + ": center is not finite");
            // 1 / sigma must be a finite float: the kernel multiplies by it.
            for (double sg : w.sigma)
                if (!(finiteInFloat(sg) && sg > 0.0 && std::isfinite(static_cast<float>(1.0 / sg)) &&
                      static_cast<float>(sg) > 0.0f))
                    throw DataError(where + ": sigma " + describe(sg) +
                                    " must be finite and > 0 (zero width)");
        }
    }
}

// The kernels' copies (cl/volcl_shared.h) of the ParaView box's constants.
static_assert(static_cast<float>(kParaViewBoxSigma) == VOLCL_PARAVIEW_BOX_SIGMA);
static_assert(static_cast<float>(kMaxImportedExtinction) == VOLCL_MAX_IMPORTED_EXTINCTION);

double TfWidget::extinction(double s, double g) const {
    if (!std::isfinite(s) || !std::isfinite(g)) return 0.0;
    if (shape == TfWidgetShape::Gaussian) {
        const double u = (s - center[0]) / sigma[0], v = (g - center[1]) / sigma[1];
        return tau * std::exp(-0.5 * (u * u + v * v));
    }
    const bool inside =
        s >= valueRange[0] && s <= valueRange[1] && g >= gradientRange[0] && g <= gradientRange[1];
    if (!inside) return 0.0;
    if (shape == TfWidgetShape::Box) return tau;
    const double u = (s - 0.5 * (valueRange[0] + valueRange[1])) /
                     (kParaViewBoxSigma * (valueRange[1] - valueRange[0])),
                 v = (g - 0.5 * (gradientRange[0] + gradientRange[1])) /
                     (kParaViewBoxSigma * (gradientRange[1] - gradientRange[0]));
    const double a = opacity * std::exp(-0.5 * (u * u + v * v));
    return std::min(-std::log1p(-std::min(a, 1.0)), kMaxImportedExtinction) / unitDistance;
}

double TransferFunction::gradientOpacityAt(double g) const {
    if (gradientOpacity.empty()) return 1.0;
    if (!std::isfinite(g)) return gradientOpacity.back().factor;
    // Same rule as the value axis (valueAt): the left value at a point, constant beyond the ends.
    const auto& pts = gradientOpacity;
    if (g <= pts.front().g) return pts.front().factor;
    if (g > pts.back().g) return pts.back().factor;
    auto it = std::lower_bound(pts.begin(), pts.end(), g,
                               [](const GradientOpacityPoint& p, double x) { return p.g < x; });
    const auto& b = *it;
    const auto& a = *(it - 1);
    return a.factor + (g - a.g) / (b.g - a.g) * (b.factor - a.factor);
}

std::array<double, 4> TransferFunction::classify(double s, double g) const {
    const auto c = colorAt(s);
    const double t1 = extinctionAt(s) * gradientOpacityAt(g);
    std::array<double, 4> sum{c[0] * t1, c[1] * t1, c[2] * t1, t1};
    for (const auto& w : widgets) {
        const double t = w.extinction(s, g);
        for (std::size_t k = 0; k < 3; ++k)
            sum[k] += w.rgb[k] * t;
        sum[3] += t;
    }
    if (!(sum[3] > 0.0)) return {c[0], c[1], c[2], 0.0};
    return {sum[0] / sum[3], sum[1] / sum[3], sum[2] / sum[3], sum[3]};
}

std::vector<VolclTfKnot> TransferFunction::packGradientOpacityKnots() const {
    if (gradientOpacity.empty()) return {};
    // The 1D machinery over g: the factor rides in the extinction channel, colour is unused.
    TransferFunction f;
    const double lo = gradientOpacity.front().g, hi = gradientOpacity.back().g;
    f.domain = {lo, hi > lo ? hi : lo + 1.0};
    f.color = {{lo, {1.0, 1.0, 1.0}}};
    for (const auto& p : gradientOpacity)
        f.extinction.push_back({p.g, p.factor});
    return f.packKnots();
}

std::vector<VolclTfKnot> TransferFunction::packGradientRecords() const {
    std::vector<VolclTfKnot> out = packGradientOpacityKnots();
    for (const auto& w : widgets) {
        VolclTfWidget r{};
        for (std::size_t c = 0; c < 3; ++c)
            r.rgbTau[c] = static_cast<float>(w.rgb[c]);
        r.rgbTau[3] = static_cast<float>(w.shape == TfWidgetShape::ParaViewBox ? w.opacity : w.tau);
        if (w.shape != TfWidgetShape::Gaussian) {
            r.shape = w.shape == TfWidgetShape::Box ? 0 : 2;
            r.invUnitDistance = static_cast<float>(1.0 / w.unitDistance);
            r.a[0] = static_cast<float>(w.valueRange[0]);
            r.a[1] = static_cast<float>(w.valueRange[1]);
            r.a[2] = static_cast<float>(w.gradientRange[0]);
            r.a[3] = static_cast<float>(w.gradientRange[1]);
        } else {
            r.shape = 1;
            r.a[0] = static_cast<float>(w.center[0]);
            r.a[1] = static_cast<float>(1.0 / w.sigma[0]);
            r.a[2] = static_cast<float>(w.center[1]);
            r.a[3] = static_cast<float>(1.0 / w.sigma[1]);
        }
        VolclTfKnot k{};
        std::memcpy(&k, &r, sizeof r);
        out.push_back(k);
    }
    return out;
}

std::array<double, 3> TransferFunction::colorAt(double s) const {
    return valueAt(color, s, [](const ColorPoint& p) { return p.rgb; });
}

double TransferFunction::extinctionAt(double s) const {
    return valueAt(extinction, s, [](const ExtinctionPoint& p) { return std::array<double, 1>{p.tau}; })[0];
}

std::vector<double> TransferFunction::breakpoints() const {
    std::set<double> s;
    for (const auto& p : color)
        if (p.s >= domain[0] && p.s <= domain[1]) s.insert(p.s);
    for (const auto& p : extinction)
        if (p.s >= domain[0] && p.s <= domain[1]) s.insert(p.s);
    return {s.begin(), s.end()};
}

double TransferFunction::maxExtinction() const {
    double m = 0.0;
    for (const auto& p : extinction)
        m = std::max(m, p.tau);
    return m;
}

double TransferFunction::maxColor() const {
    double m = 0.0;
    for (const auto& p : color)
        for (double c : p.rgb)
            m = std::max(m, c);
    return m;
}

std::vector<VolclTfKnot> TransferFunction::packKnots() const {
    validate();
    std::set<double> all;
    for (const auto& p : color)
        all.insert(p.s);
    for (const auto& p : extinction)
        all.insert(p.s);
    const std::vector<double> s(all.begin(), all.end());

    auto knot = [](float at, const std::array<double, 4>& v) {
        VolclTfKnot k{};
        k.s = at;
        for (int c = 0; c < 4; ++c)
            k.value[c] = toFloatSaturated(v[std::size_t(c)]);
        return k;
    };
    std::vector<VolclTfKnot> knots;
    knots.reserve(s.size() + 1);
    // At and below the first breakpoint the left value holds; a step there needs its own flat knot.
    const auto left0 = leftRgbt(*this, s.front());
    const auto right0 = rightRgbt(*this, s.front());
    if (left0 != right0) knots.push_back(knot(static_cast<float>(s.front()), left0));
    for (std::size_t i = 0; i < s.size(); ++i) {
        VolclTfKnot k = knot(static_cast<float>(s[i]), rightRgbt(*this, s[i]));
        if (i + 1 < s.size()) {
            const auto end = leftRgbt(*this, s[i + 1]);
            const float width = static_cast<float>(s[i + 1]) - k.s;
            // Two breakpoints that round to one float never see d > 0 in this interval: keep it flat.
            if (width > 0.0f)
                for (int c = 0; c < 4; ++c)
                    k.slope[c] = toFloatSaturated(
                        (end[std::size_t(c)] - rightRgbt(*this, s[i])[std::size_t(c)]) / (s[i + 1] - s[i]));
        }
        knots.push_back(k);
    }
    return knots;
}

std::array<float, 4> TransferFunction::sampleFloat(const std::vector<VolclTfKnot>& knots, float s) {
    if (knots.empty()) throw UsageError("TransferFunction::sampleFloat: no knots");
    // Same binary search and arithmetic as tf_sample() in cl/common/tf_lookup.h, operation for operation.
    std::uint32_t lo = 0, hi = static_cast<std::uint32_t>(knots.size());
    while (hi - lo > 1) {
        std::uint32_t mid = (lo + hi) / 2;
        if (knots[mid].s < s)
            lo = mid;
        else
            hi = mid;
    }
    const VolclTfKnot& kn = knots[lo];
    const float d = s > kn.s ? std::fmin(s - kn.s, std::numeric_limits<float>::max()) : 0.0f;
    std::array<float, 4> out{};
    for (int c = 0; c < 4; ++c) {
        const float prod = d * kn.slope[c];
        out[std::size_t(c)] = kn.value[c] + prod;
    }
    return out;
}

} // namespace volcl
