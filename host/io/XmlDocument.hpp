// XML headers of volume and mesh files (VTK XML, Voreen .vvd) parsed with pugixml; internal to volcl.
#pragma once

#include <pugixml.hpp>

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace volcl::io {

/// Parses `markup` into `doc`: one root element, no text after it, at most a million elements.
/// Malformed XML raises IoError naming `file`.
void parseXml(pugi::xml_document& doc, std::string_view markup, const std::filesystem::path& file);

/// A VTK XML file's markup. The content of its AppendedData section ('_', then raw bytes or base64 text)
/// is not XML: only the markup up to the section's start tag is parsed, closed right after that tag, and
/// the section is read by offset from the file (VtkXmlPayload).
struct VtkXmlDocument {
    pugi::xml_document xml;
    /// Offset in the file just past the <AppendedData> start tag, or npos when there is none.
    std::size_t appendedStart = std::string_view::npos;

    pugi::xml_node root() const { return xml.document_element(); }
};
void parseVtkXml(VtkXmlDocument& doc, std::string_view text, const std::filesystem::path& file);

/// The value of attribute `key`, or nullopt when the element has none.
std::optional<std::string> attr(pugi::xml_node element, const char* key);
/// The element's text: its character data and CDATA sections, concatenated.
std::string elementText(pugi::xml_node element);
/// Child elements named `name`, in document order.
std::vector<pugi::xml_node> childrenNamed(pugi::xml_node parent, const char* name);
/// Elements named `name` in the subtree of `top` (itself included), in document order.
std::vector<pugi::xml_node> elementsNamed(pugi::xml_node top, const char* name);

} // namespace volcl::io
