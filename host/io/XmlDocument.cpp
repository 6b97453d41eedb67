// XML headers parsed with pugixml: shared checks, references decoded, VTK appended data left out.
#include "host/io/XmlDocument.hpp"

#include "host/io/IoDetail.hpp"

#include <cctype>
#include <cstring>

namespace volcl::io {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kMaxElements = 1'000'000;

// Calls `fn` on every element in the subtree of `top` in document order; stops early when it returns false.
template <class Fn> void walkElements(pugi::xml_node top, Fn&& fn) {
    pugi::xml_node n = top;
    while (n) {
        if (n.type() == pugi::node_element && !fn(n)) return;
        if (pugi::xml_node c = n.first_child()) {
            n = c;
            continue;
        }
        while (n && n != top && !n.next_sibling())
            n = n.parent();
        if (!n || n == top) return;
        n = n.next_sibling();
    }
}

// Attribute values as the file spells them, with entity and character references decoded; a malformed or
// unknown reference is refused (pugixml would keep it as text).
std::string decodeEntities(std::string_view s, const fs::path& file) {
    std::string out;
    out.reserve(s.size());
    for (std::size_t i = 0; i < s.size(); ++i) {
        if (s[i] != '&') {
            out += s[i];
            continue;
        }
        const std::size_t semi = s.find(';', i);
        if (semi == std::string_view::npos || semi - i > 10) fail(file, "malformed XML entity reference");
        const std::string_view ent = s.substr(i + 1, semi - i - 1);
        if (ent == "lt")
            out += '<';
        else if (ent == "gt")
            out += '>';
        else if (ent == "amp")
            out += '&';
        else if (ent == "quot")
            out += '"';
        else if (ent == "apos")
            out += '\'';
        else if (ent.size() > 1 && ent[0] == '#') {
            const bool hex = ent[1] == 'x' || ent[1] == 'X';
            unsigned long code = 0;
            for (char c : ent.substr(hex ? 2 : 1)) {
                if (!std::isxdigit(static_cast<unsigned char>(c)) ||
                    (!hex && !std::isdigit(static_cast<unsigned char>(c))))
                    fail(file, "malformed XML character reference");
                code = code * (hex ? 16 : 10) +
                       static_cast<unsigned long>(std::isdigit(static_cast<unsigned char>(c))
                                                      ? c - '0'
                                                      : (std::tolower(c) - 'a' + 10));
                if (code > 0x10FFFF) fail(file, "malformed XML character reference");
            }
            out += code < 0x80 ? static_cast<char>(code) : '?'; // non-ASCII never matters in these headers
        } else {
            fail(file, "unknown XML entity '&" + std::string(ent) + ";'");
        }
        i = semi;
    }
    return out;
}

void decodeAttributes(pugi::xml_node top, const fs::path& file) {
    walkElements(top, [&](pugi::xml_node n) {
        for (pugi::xml_attribute a : n.attributes())
            if (std::strchr(a.value(), '&')) a.set_value(decodeEntities(a.value(), file).c_str());
        return true;
    });
}

// Parses without the document-level checks; the caller reports failures.
pugi::xml_parse_result loadMarkup(pugi::xml_document& doc, std::string_view markup) {
    // Text and attribute values stay as the file spells them (no entity decoding, end-of-line or
    // whitespace conversion): decodeAttributes checks and decodes references. parse_fragment keeps text
    // outside the root element, so that parseXml can refuse it.
    return doc.load_buffer(markup.data(), markup.size(), pugi::parse_cdata | pugi::parse_fragment,
                           pugi::encoding_utf8);
}

[[noreturn]] void failParse(const pugi::xml_parse_result& r, std::size_t size, const fs::path& file) {
    const auto at = static_cast<std::size_t>(r.offset);
    if (at + 1 >= size) fail(file, std::string("truncated XML (") + r.description() + ")");
    fail(file, std::string("malformed XML (") + r.description() + " at byte " + std::to_string(at) + ")");
}

// One root element, nothing but whitespace outside it, at most kMaxElements elements.
void checkDocument(const pugi::xml_document& doc, const fs::path& file) {
    bool rootSeen = false;
    for (pugi::xml_node n : doc.children()) {
        if (n.type() == pugi::node_element) {
            if (rootSeen) fail(file, "more than one XML root element");
            rootSeen = true;
        } else if (rootSeen && n.type() == pugi::node_pcdata && !trim(n.value()).empty()) {
            fail(file, "text after the XML root element");
        }
    }
    if (!rootSeen) fail(file, "no XML content");
    std::size_t elements = 0;
    walkElements(doc, [&](pugi::xml_node) { return ++elements <= kMaxElements; });
    if (elements > kMaxElements) fail(file, "too many XML elements");
}

// Where the next <AppendedData start tag from `from` on ends (just past its '>'), or npos. `selfClosing`
// tells whether it is written <AppendedData .../>.
std::size_t appendedTagEnd(std::string_view text, std::size_t from, bool& selfClosing) {
    constexpr std::string_view kTag = "<AppendedData";
    for (std::size_t at = text.find(kTag, from); at != std::string_view::npos; at = text.find(kTag, at + 1)) {
        std::size_t p = at + kTag.size();
        if (p < text.size() && !std::isspace(static_cast<unsigned char>(text[p])) && text[p] != '>' &&
            text[p] != '/')
            continue; // a longer name
        char quote = 0;
        for (; p < text.size(); ++p) {
            const char c = text[p];
            if (quote) {
                if (c == quote) quote = 0;
            } else if (c == '"' || c == '\'') {
                quote = c;
            } else if (c == '>') {
                selfClosing = text[p - 1] == '/';
                return p + 1;
            }
        }
        return std::string_view::npos; // the tag is cut off: the whole file is parsed and refused as XML
    }
    return std::string_view::npos;
}

} // namespace

void parseXml(pugi::xml_document& doc, std::string_view markup, const fs::path& file) {
    const pugi::xml_parse_result r = loadMarkup(doc, markup);
    if (!r) failParse(r, markup.size(), file);
    checkDocument(doc, file);
    decodeAttributes(doc, file);
    // pugixml ends the document at a NUL byte: with the root element complete, the NUL follows it.
    if (markup.find('\0') != std::string_view::npos) fail(file, "text after the XML root element");
}

void parseVtkXml(VtkXmlDocument& doc, std::string_view text, const fs::path& file) {
    bool selfClosing = false;
    for (std::size_t tagEnd = appendedTagEnd(text, 0, selfClosing); tagEnd != std::string_view::npos;
         tagEnd = appendedTagEnd(text, tagEnd, selfClosing)) {
        // The markup before the section leaves AppendedData and its ancestors open: parsed alone it stops
        // at its end with them in the tree, which names the end tags that close it.
        const std::string_view head = text.substr(0, tagEnd);
        const pugi::xml_parse_result open = loadMarkup(doc.xml, head);
        pugi::xml_node appended;
        walkElements(doc.xml, [&](pugi::xml_node n) {
            if (std::strcmp(n.name(), "AppendedData") == 0) appended = n;
            return !appended;
        });
        if (!appended) {
            // A parse that ends cleanly or runs out at the tag's end found the text inside a comment, a
            // processing instruction or an attribute value: the section starts at a later one, if any.
            if (open || static_cast<std::size_t>(open.offset) + 1 >= head.size()) continue;
            failParse(open, head.size(), file);
        }
        std::string markup(head);
        if (!selfClosing) markup += "</AppendedData>";
        for (pugi::xml_node n = appended.parent(); n.type() == pugi::node_element; n = n.parent())
            markup += std::string("</") + n.name() + ">";
        parseXml(doc.xml, markup, file);
        doc.appendedStart = tagEnd;
        return;
    }
    parseXml(doc.xml, text, file);
}

std::optional<std::string> attr(pugi::xml_node element, const char* key) {
    const pugi::xml_attribute a = element.attribute(key);
    if (!a) return std::nullopt;
    return std::string(a.value());
}

std::string elementText(pugi::xml_node element) {
    std::string out;
    for (pugi::xml_node c : element.children())
        if (c.type() == pugi::node_pcdata || c.type() == pugi::node_cdata) out += c.value();
    return out;
}

std::vector<pugi::xml_node> childrenNamed(pugi::xml_node parent, const char* name) {
    std::vector<pugi::xml_node> out;
    for (pugi::xml_node c : parent.children(name))
        out.push_back(c);
    return out;
}

std::vector<pugi::xml_node> elementsNamed(pugi::xml_node top, const char* name) {
    std::vector<pugi::xml_node> out;
    walkElements(top, [&](pugi::xml_node n) {
        if (std::strcmp(n.name(), name) == 0) out.push_back(n);
        return true;
    });
    return out;
}

} // namespace volcl::io
