// Label tables: the JSON form, the text forms of ITK-SNAP, Slicer and FSL/mricron, mricron's binary palette.
#include "host/tf/LabelTable.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "host/tf/ColorSpaces.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <optional>
#include <sstream>
#include <type_traits>
#include <vector>

namespace volcl {
namespace {

using json = nlohmann::json;

std::string readAll(const std::filesystem::path& path) {
    requireRegularFile(path);
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError(path.string() + ": cannot open label table");
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

/// A mricron .lut: 256 reds, then 256 greens, then 256 blues, one byte each.
std::array<std::array<double, 3>, 256> readLut(const std::filesystem::path& path) {
    const std::string bytes = readAll(path);
    if (bytes.size() != 768)
        throw DataError(path.string() + ": a mricron .lut palette holds 768 bytes, this one " +
                        std::to_string(bytes.size()));
    std::array<std::array<double, 3>, 256> rgb{};
    for (int i = 0; i < 256; ++i)
        for (int c = 0; c < 3; ++c)
            rgb[std::size_t(i)][std::size_t(c)] =
                double(static_cast<unsigned char>(bytes[std::size_t(c * 256 + i)])) / 255.0;
    return rgb;
}

/// The whole token `t` as a long or a finite double; false for anything else.
template <class T> bool parseWhole(const std::string& t, T& out) {
    if (t.empty()) return false;
    std::size_t used = 0;
    try {
        if constexpr (std::is_same_v<T, long>)
            out = std::stol(t, &used);
        else
            out = std::stod(t, &used);
    } catch (const std::exception&) {
        return false;
    }
    return used == t.size() && std::isfinite(double(out));
}

/// Labels a table may name: the label volumes volcl reads are uint8, uint16 or int16.
void checkLabel(long label, const std::string& where) {
    if (label < 0 || label > 65535)
        throw DataError(where + ": label " + std::to_string(label) + " is outside 0..65535");
}

/// One line of a text table into `table`; `palette`: the .lut beside an id-name file, if any.
void parseTextLine(const std::string& line, const std::string& where,
                   const std::array<std::array<double, 3>, 256>* palette, LabelTable& table) {
    std::string body = line;
    std::string quoted;
    const auto q0 = body.find('"');
    if (q0 != std::string::npos) {
        const auto q1 = body.find('"', q0 + 1);
        if (q1 == std::string::npos) throw DataError(where + ": unterminated quoted name");
        quoted = body.substr(q0 + 1, q1 - q0 - 1);
        body = body.substr(0, q0);
    }
    std::istringstream in(body);
    std::vector<std::string> tok;
    for (std::string t; in >> t;)
        tok.push_back(t);
    long id = 0;
    if (tok.empty() || !parseWhole(tok[0], id))
        throw DataError(where + ": expected a label number first, got '" + (tok.empty() ? line : tok[0]) +
                        "'");
    checkLabel(id, where);
    LabelEntry e;
    if (q0 != std::string::npos) {
        // ITK-SNAP: IDX R G B A VIS MESH "name", colours 0..255, alpha 0..1.
        double v[6];
        if (tok.size() != 7)
            throw DataError(where + ": an ITK-SNAP label line is 'IDX R G B A VIS MSH \"name\"'");
        for (int i = 0; i < 6; ++i)
            if (!parseWhole(tok[std::size_t(i + 1)], v[i]))
                throw DataError(where + ": '" + tok[std::size_t(i + 1)] + "' is not a number");
        for (int c = 0; c < 3; ++c) {
            if (v[c] < 0.0 || v[c] > 255.0) throw DataError(where + ": colour values must be in 0..255");
            e.rgb[std::size_t(c)] = v[c] / 255.0;
        }
        if (v[3] < 0.0 || v[3] > 1.0) throw DataError(where + ": ITK-SNAP alpha must be in [0, 1]");
        e.opacity = v[3];
        e.visible = v[4] != 0.0 && v[3] > 0.0;
        e.name = quoted;
    } else {
        if (tok.size() < 2) throw DataError(where + ": expected 'id name ...'");
        e.name = tok[1];
        double v[4];
        bool slicer = tok.size() == 6;
        for (int i = 0; slicer && i < 4; ++i)
            slicer = parseWhole(tok[std::size_t(i + 2)], v[i]);
        if (slicer) {
            // Slicer colour table: id name r g b a, 0..255.
            for (int i = 0; i < 4; ++i)
                if (v[i] < 0.0 || v[i] > 255.0) throw DataError(where + ": colour values must be in 0..255");
            e.rgb = {v[0] / 255.0, v[1] / 255.0, v[2] / 255.0};
            e.opacity = v[3] / 255.0;
            e.visible = v[3] > 0.0;
        } else {
            // FSL / mricron: id name [anything]; the colour from the palette beside it, else the default.
            const LabelEntry d = defaultLabelEntry(id);
            e.rgb = palette && id < 256 ? (*palette)[std::size_t(id)] : d.rgb;
        }
    }
    table.set(id, e);
}

/// The text and palette forms name label 0 ("Unclassified", "Clear Label", black) but never mean it as a
/// segment: only a JSON table makes it visible.
LabelTable withLabel0Unlabelled(LabelTable t) {
    if (t.listed().count(0)) {
        LabelEntry e = t.listed().at(0);
        e.visible = false;
        t.set(0, e);
    }
    return t;
}

} // namespace

LabelEntry defaultLabelEntry(long label) {
    const double golden = 0.6180339887498949;
    const double h = std::fmod(double(label) * golden, 1.0);
    LabelEntry e;
    e.rgb = hsvToRgb({h, 0.65, 0.95});
    e.name = "label " + std::to_string(label);
    return e;
}

LabelEntry LabelTable::entry(long label) const {
    const auto it = entries_.find(label);
    return it != entries_.end() ? it->second : defaultLabelEntry(label);
}

LabelState LabelTable::state(long label) const {
    const auto it = entries_.find(label);
    if (label == 0 && (it == entries_.end() || !it->second.visible)) return LabelState::Unlabelled;
    if (it == entries_.end()) return LabelState::Visible;
    return it->second.visible && it->second.opacity > 0.0 ? LabelState::Visible : LabelState::Hidden;
}

LabelTable LabelTable::fromJson(std::string_view text, const std::string& where) {
    json j;
    try {
        j = json::parse(text);
    } catch (const json::exception& e) {
        throw DataError(where + ": not JSON (" + e.what() + ")");
    }
    if (!j.is_object() || !j.contains("labels") || !j["labels"].is_array())
        throw DataError(where + ": a label table is {\"labels\": [{\"label\": N, ...}, ...]}");
    for (const auto& [key, value] : j.items())
        if (key != "labels" && key != "name") throw DataError(where + ": unknown key '" + key + "'");
    LabelTable t;
    std::size_t i = 0;
    for (const json& l : j["labels"]) {
        const std::string at = where + ": labels[" + std::to_string(i++) + "]";
        if (!l.is_object() || !l.contains("label") || !l["label"].is_number_integer())
            throw DataError(at + " needs an integer 'label'");
        const long id = l["label"].get<long>();
        checkLabel(id, at);
        LabelEntry e = defaultLabelEntry(id);
        for (const auto& [key, value] : l.items()) {
            if (key == "label") continue;
            if (key == "name") {
                if (!value.is_string()) throw DataError(at + ".name must be a string");
                e.name = value.get<std::string>();
            } else if (key == "color") {
                if (!value.is_array() || value.size() != 3)
                    throw DataError(at + ".color must be [r, g, b] in [0, 1]");
                for (std::size_t c = 0; c < 3; ++c) {
                    if (!value[c].is_number() ||
                        !(value[c].get<double>() >= 0.0 && value[c].get<double>() <= 1.0))
                        throw DataError(at + ".color must be [r, g, b] in [0, 1]");
                    e.rgb[c] = value[c].get<double>();
                }
            } else if (key == "opacity") {
                if (!value.is_number() || !(value.get<double>() >= 0.0 && value.get<double>() <= 1.0))
                    throw DataError(at + ".opacity must be in [0, 1]");
                e.opacity = value.get<double>();
            } else if (key == "visible") {
                if (!value.is_boolean()) throw DataError(at + ".visible must be true or false");
                e.visible = value.get<bool>();
            } else {
                throw DataError(at + ": unknown key '" + key + "'");
            }
        }
        t.set(id, e);
    }
    return t;
}

LabelTable LabelTable::read(const std::filesystem::path& path) {
    const std::string ext = path.extension().string();
    if (ext == ".json") return fromJson(readAll(path), path.string());
    LabelTable t;
    if (ext == ".lut") {
        const auto rgb = readLut(path);
        for (long i = 0; i < 256; ++i) {
            LabelEntry e;
            e.rgb = rgb[std::size_t(i)];
            e.name = "label " + std::to_string(i);
            t.set(i, e);
        }
        return withLabel0Unlabelled(std::move(t));
    }
    std::filesystem::path lut = path;
    lut.replace_extension(".lut");
    std::optional<std::array<std::array<double, 3>, 256>> palette;
    if (std::filesystem::is_regular_file(lut)) palette = readLut(lut);
    std::istringstream in(readAll(path));
    std::size_t lineNo = 0, entries = 0;
    for (std::string line; std::getline(in, line);) {
        ++lineNo;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const auto first = line.find_first_not_of(" \t");
        if (first == std::string::npos || line[first] == '#') continue;
        parseTextLine(line, path.string() + ": line " + std::to_string(lineNo), palette ? &*palette : nullptr,
                      t);
        ++entries;
    }
    if (entries == 0) throw DataError(path.string() + ": no labels in the label table");
    return withLabel0Unlabelled(std::move(t));
}

} // namespace volcl
