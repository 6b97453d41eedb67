// A small non-validating XML scanner for volume headers (VTK .vti, Voreen .vvd); internal to host/io.
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace volcl::io {

struct XmlElement {
    std::string name;
    std::vector<std::pair<std::string, std::string>> attributes; ///< entity references decoded
    std::string_view content;                                    ///< raw text between start and end tag
    int parent = -1;
    std::vector<int> children;

    std::optional<std::string> attr(std::string_view key) const;
};

/// Elements in document order; element 0 is the root. Views point into the scanned text.
struct XmlDocument {
    std::vector<XmlElement> elements;
    /// Offset just past the start tag named by `stopAt` (VTK appended binary data follows it), or npos.
    std::size_t stopOffset = std::string_view::npos;

    std::vector<int> childrenNamed(int parent, std::string_view name) const;
    /// First element with this name in document order, or -1.
    int find(std::string_view name) const;
};

/// Scans `text`, stopping after the start tag `stopAt` when given (its subtree is not scanned).
/// Malformed or truncated markup raises IoError naming `file`.
XmlDocument scanXml(std::string_view text, const std::filesystem::path& file, std::string_view stopAt = {});

} // namespace volcl::io
