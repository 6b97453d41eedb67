// XML scanning for volume headers: elements, attributes, text ranges; enough for VTK and Voreen files.
#include "host/io/XmlScan.hpp"

#include "host/io/IoDetail.hpp"

#include <cctype>

namespace volcl::io {

namespace fs = std::filesystem;

std::optional<std::string> XmlElement::attr(std::string_view key) const {
    for (const auto& [k, v] : attributes)
        if (k == key) return v;
    return std::nullopt;
}

std::vector<int> XmlDocument::childrenNamed(int parent, std::string_view name) const {
    std::vector<int> out;
    if (parent < 0 || parent >= static_cast<int>(elements.size())) return out;
    for (int c : elements[static_cast<std::size_t>(parent)].children)
        if (elements[static_cast<std::size_t>(c)].name == name) out.push_back(c);
    return out;
}

int XmlDocument::find(std::string_view name) const {
    for (std::size_t i = 0; i < elements.size(); ++i)
        if (elements[i].name == name) return static_cast<int>(i);
    return -1;
}

namespace {

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

bool isNameChar(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == ':';
}

} // namespace

XmlDocument scanXml(std::string_view text, const fs::path& file, std::string_view stopAt) {
    XmlDocument doc;
    std::vector<int> stack;
    std::vector<std::size_t> contentStart;
    std::size_t pos = 0;
    constexpr std::size_t kMaxElements = 1'000'000;
    auto expect = [&](std::string_view closing, std::size_t from) {
        const std::size_t e = text.find(closing, from);
        if (e == std::string_view::npos) fail(file, "truncated XML: '" + std::string(closing) + "' missing");
        return e + closing.size();
    };
    while (true) {
        const std::size_t lt = text.find('<', pos);
        if (lt == std::string_view::npos) {
            if (!stack.empty())
                fail(file, "truncated XML: <" + doc.elements[static_cast<std::size_t>(stack.back())].name +
                               "> is not closed");
            if (!trim(text.substr(pos)).empty() && !doc.elements.empty())
                fail(file, "text after the XML root element");
            break;
        }
        if (stack.empty() && !doc.elements.empty() && !trim(text.substr(pos, lt - pos)).empty())
            fail(file, "text after the XML root element");
        const std::string_view rest = text.substr(lt);
        if (rest.starts_with("<?")) {
            pos = expect("?>", lt + 2);
            continue;
        }
        if (rest.starts_with("<!--")) {
            pos = expect("-->", lt + 4);
            continue;
        }
        if (rest.starts_with("<![CDATA[")) {
            pos = expect("]]>", lt + 9);
            continue;
        }
        if (rest.starts_with("<!")) {
            pos = expect(">", lt + 2);
            continue;
        }
        if (rest.starts_with("</")) {
            std::size_t p = lt + 2;
            const std::size_t nameBegin = p;
            while (p < text.size() && isNameChar(text[p]))
                ++p;
            const std::string_view name = text.substr(nameBegin, p - nameBegin);
            while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p])))
                ++p;
            if (p >= text.size() || text[p] != '>')
                fail(file, "truncated or malformed XML end tag </" + std::string(name));
            if (stack.empty() || doc.elements[static_cast<std::size_t>(stack.back())].name != name)
                fail(file, "mismatched XML end tag </" + std::string(name) + ">");
            XmlElement& e = doc.elements[static_cast<std::size_t>(stack.back())];
            e.content = text.substr(contentStart.back(), lt - contentStart.back());
            stack.pop_back();
            contentStart.pop_back();
            pos = p + 1;
            continue;
        }
        // Start tag.
        if (stack.empty() && !doc.elements.empty()) fail(file, "more than one XML root element");
        if (doc.elements.size() >= kMaxElements) fail(file, "too many XML elements");
        std::size_t p = lt + 1;
        const std::size_t nameBegin = p;
        while (p < text.size() && isNameChar(text[p]))
            ++p;
        XmlElement el;
        el.name = std::string(text.substr(nameBegin, p - nameBegin));
        if (el.name.empty()) fail(file, "malformed XML tag");
        bool selfClosing = false;
        while (true) {
            while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p])))
                ++p;
            if (p >= text.size()) fail(file, "truncated XML tag <" + el.name);
            if (text[p] == '>') {
                ++p;
                break;
            }
            if (text[p] == '/') {
                if (p + 1 >= text.size() || text[p + 1] != '>') fail(file, "malformed XML tag <" + el.name);
                selfClosing = true;
                p += 2;
                break;
            }
            const std::size_t keyBegin = p;
            while (p < text.size() && isNameChar(text[p]))
                ++p;
            const std::string_view key = text.substr(keyBegin, p - keyBegin);
            while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p])))
                ++p;
            if (key.empty() || p >= text.size() || text[p] != '=')
                fail(file, "malformed attribute in XML tag <" + el.name);
            ++p;
            while (p < text.size() && std::isspace(static_cast<unsigned char>(text[p])))
                ++p;
            if (p >= text.size() || (text[p] != '"' && text[p] != '\''))
                fail(file, "unquoted or truncated attribute value in XML tag <" + el.name);
            const char quote = text[p++];
            const std::size_t close = text.find(quote, p);
            if (close == std::string_view::npos)
                fail(file, "truncated attribute value in XML tag <" + el.name);
            el.attributes.emplace_back(std::string(key), decodeEntities(text.substr(p, close - p), file));
            p = close + 1;
        }
        const int index = static_cast<int>(doc.elements.size());
        el.parent = stack.empty() ? -1 : stack.back();
        if (el.parent >= 0) doc.elements[static_cast<std::size_t>(el.parent)].children.push_back(index);
        const bool stop = !stopAt.empty() && el.name == stopAt;
        doc.elements.push_back(std::move(el));
        pos = p;
        if (stop) {
            doc.stopOffset = p;
            break;
        }
        if (!selfClosing) {
            stack.push_back(index);
            contentStart.push_back(p);
        }
    }
    if (doc.elements.empty()) fail(file, "no XML content");
    return doc;
}

} // namespace volcl::io
