// The 2D transfer function of a ParaView state file (.pvsm XML): its boxes as ParaView-box widgets.
#include "core/Error.hpp"
#include "core/Format.hpp"
#include "host/io/XmlDocument.hpp"
#include "host/tf/TransferFunction.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace volcl {
namespace {

// ParaView stores a box as 8 numbers: x, y, width, height (value and gradient axes), r, g, b, opacity
// (vtkSMTransferFunction2DProxy::BOX_PROPERTY_SIZE).
constexpr std::size_t kBoxNumbers = 8;

pugi::xml_node property(pugi::xml_node proxy, const char* name) {
    for (pugi::xml_node p : io::childrenNamed(proxy, "Property"))
        if (io::attr(p, "name") == name) return p;
    return {};
}

/// A property's <Element index= value=> numbers in index order; a value that is not a number is refused.
std::vector<double> numbers(pugi::xml_node prop, const std::string& where) {
    std::map<long long, double> byIndex;
    for (pugi::xml_node e : io::childrenNamed(prop, "Element")) {
        const auto index = io::attr(e, "index"), value = io::attr(e, "value");
        if (!index || !value) throw DataError(where + ": an <Element> without index or value");
        std::size_t used = 0, usedIndex = 0;
        double v = 0.0;
        long long i = 0;
        try {
            v = std::stod(*value, &used);
            i = std::stoll(*index, &usedIndex);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used != value->size() || usedIndex != index->size() || i < 0)
            throw DataError(where + ": element '" + *index + "' = '" + *value + "' is not a number");
        byIndex[i] = v;
    }
    std::vector<double> out;
    for (const auto& [i, v] : byIndex)
        out.push_back(v);
    return out;
}

/// The id of the proxy a proxy property points at (<Proxy value="ID"/>), or "".
std::string target(pugi::xml_node prop) {
    for (pugi::xml_node p : io::childrenNamed(prop, "Proxy"))
        if (auto v = io::attr(p, "value")) return *v;
    return "";
}

double single(pugi::xml_node proxy, const char* name, double fallback, const std::string& where) {
    const pugi::xml_node p = property(proxy, name);
    if (!p) return fallback;
    const std::vector<double> v = numbers(p, where + " " + name);
    return v.empty() ? fallback : v.front();
}

} // namespace

TransferFunction TransferFunction::fromParaViewState(std::string_view xml, const std::string& name,
                                                     double opacityUnitDistance) {
    pugi::xml_document doc;
    io::parseXml(doc, xml, name);
    const pugi::xml_node root = doc.document_element();
    // ParaView writes <GenericParaViewApplication> (older versions <ParaView>) around <ServerManagerState>.
    if (io::elementsNamed(root, "ServerManagerState").empty())
        throw DataError("not a ParaView state (no <ServerManagerState> under <" + std::string(root.name()) +
                        ">)");
    struct Function2D {
        std::vector<double> boxes, range;
    };
    std::map<std::string, Function2D> functions;
    struct User {
        std::string function;
        double unitDistance, useGradient;
    };
    std::vector<User> users;
    for (pugi::xml_node proxy : io::elementsNamed(root, "Proxy")) {
        const std::string group = io::attr(proxy, "group").value_or(""),
                          id = io::attr(proxy, "id").value_or("");
        if (group == "transfer_2d_functions") {
            const std::string where = "2D transfer function " + id;
            Function2D f;
            if (pugi::xml_node b = property(proxy, "Boxes")) f.boxes = numbers(b, where + " Boxes");
            if (pugi::xml_node r = property(proxy, "Range")) f.range = numbers(r, where + " Range");
            functions[id] = f;
        } else if (group == "representations" &&
                   single(proxy, "UseTransfer2D", 0.0, "representation " + id)) {
            const std::string where = "representation " + id;
            users.push_back({target(property(proxy, "TransferFunction2D")),
                             single(proxy, "ScalarOpacityUnitDistance", opacityUnitDistance, where),
                             single(proxy, "UseGradientForTransfer2D", 1.0, where)});
        }
    }
    std::set<std::string> used;
    for (const User& u : users)
        if (functions.count(u.function)) used.insert(u.function);
    std::string chosen;
    if (used.size() > 1)
        throw DataError("ParaView state: " + std::to_string(used.size()) +
                        " 2D transfer functions are in use; volcl reads a state that uses one");
    if (used.size() == 1) {
        chosen = *used.begin();
    } else {
        // No representation uses one (a state saved before the 2D mode was switched on): the one with boxes.
        std::vector<std::string> withBoxes;
        for (const auto& [id, f] : functions)
            if (!f.boxes.empty()) withBoxes.push_back(id);
        if (withBoxes.size() != 1)
            throw DataError("ParaView state: " + std::to_string(withBoxes.size()) +
                            " 2D transfer functions with boxes and none in use; volcl reads one");
        chosen = withBoxes.front();
    }
    double unitDistance = opacityUnitDistance;
    bool first = true;
    for (const User& u : users) {
        if (u.function != chosen) continue;
        if (u.useGradient == 0.0)
            throw DataError("ParaView state: the 2D transfer function's second axis is another array; "
                            "volcl's is the gradient magnitude");
        if (!first && u.unitDistance != unitDistance)
            throw DataError("ParaView state: representations use the 2D transfer function with opacity unit "
                            "distances " +
                            formatNumber(unitDistance) + " and " + formatNumber(u.unitDistance));
        unitDistance = u.unitDistance;
        first = false;
    }
    const Function2D& f = functions[chosen];
    if (f.boxes.empty()) throw DataError("ParaView state: the 2D transfer function in use has no boxes");
    if (f.boxes.size() % kBoxNumbers != 0)
        throw DataError("ParaView state: 2D transfer function boxes hold " + std::to_string(f.boxes.size()) +
                        " numbers, not groups of 8 (x, y, width, height, r, g, b, opacity)");
    if (f.boxes.size() / kBoxNumbers > kMaxTfWidgets)
        throw DataError("ParaView state: " + std::to_string(f.boxes.size() / kBoxNumbers) +
                        " boxes, more than the " + std::to_string(kMaxTfWidgets) +
                        " widgets a transfer function may have");

    TransferFunction tf;
    double lo = INFINITY, hi = -INFINITY;
    for (std::size_t i = 0; i < f.boxes.size(); i += kBoxNumbers) {
        const double* b = f.boxes.data() + i;
        TfWidget w;
        w.shape = TfWidgetShape::ParaViewBox;
        w.valueRange = {b[0], b[0] + b[2]};
        w.gradientRange = {b[1], b[1] + b[3]};
        w.rgb = {b[4], b[5], b[6]};
        w.opacity = b[7];
        w.unitDistance = unitDistance;
        if (!(b[2] > 0.0 && b[3] > 0.0))
            throw DataError("ParaView state: box " + std::to_string(i / kBoxNumbers) + " has zero width (" +
                            formatNumber(b[2]) + " x " + formatNumber(b[3]) + ")");
        for (double c : w.rgb)
            if (!(c >= 0.0 && c <= 1.0))
                throw DataError("ParaView state: box " + std::to_string(i / kBoxNumbers) + ": colour " +
                                formatNumber(c) + " is outside [0, 1]");
        lo = std::min(lo, w.valueRange[0]);
        hi = std::max(hi, w.valueRange[1]);
        tf.widgets.push_back(w);
    }
    // In ParaView's 2D mode colour and opacity come from the 2D function alone: the value axis adds nothing.
    if (f.range.size() == 4 && std::isfinite(f.range[0]) && std::isfinite(f.range[1]) &&
        f.range[0] < f.range[1])
        lo = std::min(lo, f.range[0]), hi = std::max(hi, f.range[1]);
    tf.domain = {lo, hi};
    tf.color = {{lo, {0.0, 0.0, 0.0}}, {hi, {0.0, 0.0, 0.0}}};
    tf.extinction = {{lo, 0.0}, {hi, 0.0}};
    tf.normalized = false;
    tf.validate();
    return tf;
}

} // namespace volcl
