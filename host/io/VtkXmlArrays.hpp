// VTK XML DataArray payloads (internal to volcl): byte order, header words, zlib blocks, base64, appended
// data.
#pragma once

#include "host/io/IoDetail.hpp"
#include "host/io/XmlDocument.hpp"

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace volcl::io {

/// VTK XML type names (Int8 ... Float64, and the older Char/UChar).
std::optional<SampleType> vtkXmlType(std::string_view name);

/// How a VTK XML file stores its binary arrays (from the root element's attributes).
struct VtkXmlLayout {
    std::filesystem::path file;
    bool swap = false; ///< file byte order differs from the host
    Endian endian = Endian::Little;
    std::size_t headerWord = 4; ///< UInt32 or UInt64 block headers
    bool compressed = false;    ///< vtkZLibDataCompressor
};

/// Reads `byte_order`, `header_type` and `compressor` of the <VTKFile> root element.
VtkXmlLayout vtkXmlLayout(pugi::xml_node root, const std::filesystem::path& file);

/// The binary payloads of one VTK XML file: inline base64 arrays and the AppendedData section (raw or
/// base64). The constructor locates the appended section and checks that every appended array ends
/// inside it and that nothing but whitespace follows the last one.
class VtkXmlPayload {
public:
    /// `doc` must be parsed from `bytes` by parseVtkXml.
    VtkXmlPayload(const VtkXmlDocument& doc, std::span<const std::byte> bytes, VtkXmlLayout layout);
    /// Decoded bytes of a `binary` or `appended` DataArray; they must be exactly `expectedBytes` long.
    std::vector<std::byte> decode(pugi::xml_node dataArray, std::size_t expectedBytes) const;
    const VtkXmlLayout& layout() const noexcept { return layout_; }

private:
    VtkXmlLayout layout_;
    std::string_view text_;
    std::span<const std::byte> appended_;
    bool hasAppended_ = false;
    bool appendedBase64_ = false;
};

/// Standard base64 with '=' padding (what VTK's inline `binary` and base64 appended formats hold).
std::string base64Encode(std::span<const std::byte> bytes);

/// `v` appended in little-endian byte order (VTK XML writers write little-endian files).
template <class T> void appendLittle(std::vector<std::byte>& out, T v) {
    std::byte b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (!hostIsLittleEndian()) std::reverse(b, b + sizeof(T));
    out.insert(out.end(), b, b + sizeof(T));
}

/// One array as a writer stores it with header_type UInt64: the header words (byte count, or block
/// count, block size, last block size and each compressed size) and the data (raw, or zlib blocks of
/// 32 KiB as VTK writes them).
struct VtkXmlEncodedArray {
    std::vector<std::byte> header, data;
};
VtkXmlEncodedArray encodeVtkXmlArray(std::span<const std::byte> raw, bool zlib);

/// `s` with &, <, > and " escaped for an XML attribute value.
std::string xmlEscape(std::string_view s);

/// Text without its whitespace (base64 runs may be broken into lines).
std::string stripSpaces(std::string_view s);

} // namespace volcl::io
