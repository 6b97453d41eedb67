// Label tables: colour, opacity, visibility and name per integer label, read from JSON or the usual text files.
#pragma once

#include <array>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>

namespace volcl {

/// What a label's samples show. Unlabelled: not a segment at all (label 0 unless a table makes it visible, and
/// everything outside the label grid); Hidden: a segment cut away (its samples show nothing in every mode).
enum class LabelState { Visible, Hidden, Unlabelled };

/// One label: straight colour in [0, 1], opacity in [0, 1] (as the NaN colour's: extinction -ln(1 - a) per
/// world unit, docs/labels.md), visibility and name.
struct LabelEntry {
    std::array<double, 3> rgb{1, 1, 1};
    double opacity = 1.0;
    bool visible = true;
    std::string name;
};

/// A label table. Labels it does not list take defaultLabelEntry(); label 0 is unlabelled unless the table
/// lists it visible. Example:
/// ```
/// volcl::LabelTable t = volcl::LabelTable::read("aal.nii.txt");   // id name, colours from aal.nii.lut
/// volcl::LabelEntry e = t.entry(3);
/// ```
class LabelTable {
public:
    /// Reads a label table: `.json` (readJson), a mricron binary `.lut` palette (768 bytes: 256 reds, greens,
    /// blues), or a text file of one label per line: ITK-SNAP label descriptions (`id r g b a vis mesh
    /// "name"`), Slicer colour tables (`id name r g b a`, 0-255) or FSL/mricron `id name [...]` (colours from a
    /// `.lut` of the same stem beside it, else the default palette). `#` starts a comment. Throws DataError
    /// naming the file and line for anything else, IoError when it cannot be read.
    static LabelTable read(const std::filesystem::path& path);
    /// `{"labels": [{"label": 1, "name": "liver", "color": [r, g, b], "opacity": 1, "visible": true}, ...]}`
    /// with colours in [0, 1] (only `label` is required). Throws DataError naming `where`.
    static LabelTable fromJson(std::string_view text, const std::string& where);

    /// The label's entry: listed, else the default palette's.
    LabelEntry entry(long label) const;
    /// Visible, Hidden, or Unlabelled (label 0 not listed visible).
    LabelState state(long label) const;
    const std::map<long, LabelEntry>& listed() const noexcept { return entries_; }
    void set(long label, LabelEntry e) { entries_[label] = std::move(e); }

private:
    std::map<long, LabelEntry> entries_;
};

/// The palette of labels no table lists: hue advancing by the golden ratio per label (distinct neighbours,
/// the same colour for a label in every run), saturation 0.65, value 0.95, opacity 1, visible.
LabelEntry defaultLabelEntry(long label);

} // namespace volcl
