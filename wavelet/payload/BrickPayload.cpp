// Framing of brick payloads: section sizes, sections, corrections.
#include "wavelet/payload/BrickPayload.hpp"

#include "core/Error.hpp"
#include "wavelet/entropy/EntropyCoder.hpp"

#include <cstring>

namespace volcl::codec {

std::vector<std::uint8_t> buildPayload(const VczHeader& h, Dims d, std::span<const std::int32_t> q,
                                       const std::vector<Correction>& corr, std::size_t pitch) {
    const int levels = h.transform == TransformKind::RawBits ? 0 : h.levels;
    const auto layout = sectionLayout(d, levels);
    const Dims storage{pitch ? pitch : d.x, d.y, d.z};
    std::vector<std::vector<std::uint8_t>> sections(layout.size());
    std::uint32_t setPartitioned = 0;
    for (std::size_t s = 0; s < layout.size(); ++s)
        if (encodeSectionSmallest(q, storage, layout, s, h.entropy, sections[s])) setPartitioned |= 1u << s;
    std::vector<std::uint8_t> corrBytes;
    if (!corr.empty()) corrBytes = encodeCorrections(corr, h.type);
    std::vector<std::uint8_t> out;
    out.push_back(static_cast<std::uint8_t>(layout.size()));
    out.push_back(static_cast<std::uint8_t>((corr.empty() ? 0 : 1) | (setPartitioned ? 2 : 0)));
    if (setPartitioned)
        for (std::size_t s = 0; s < layout.size(); s += 8)
            out.push_back(static_cast<std::uint8_t>(setPartitioned >> s));
    auto put32 = [&](std::size_t v) {
        const auto u = static_cast<std::uint32_t>(v);
        out.insert(out.end(), reinterpret_cast<const std::uint8_t*>(&u),
                   reinterpret_cast<const std::uint8_t*>(&u) + 4);
    };
    for (const auto& s : sections)
        put32(s.size());
    put32(corrBytes.size());
    for (const auto& s : sections)
        out.insert(out.end(), s.begin(), s.end());
    out.insert(out.end(), corrBytes.begin(), corrBytes.end());
    return out;
}

ParsedPayload parsePayload(std::span<const std::uint8_t> p, std::size_t expectedSections,
                           const std::string& what) {
    if (p.size() < 2 || p[0] != expectedSections || p[1] > 3) throw IoError(what + ": invalid brick header");
    std::size_t pos = 2;
    std::uint32_t setPartitioned = 0;
    if (p[1] & 2) {
        const std::size_t maskBytes = (expectedSections + 7) / 8;
        if (p.size() - pos < maskBytes) throw IoError(what + ": truncated brick header");
        for (std::size_t i = 0; i < maskBytes; ++i)
            setPartitioned |= std::uint32_t(p[pos + i]) << (8 * i);
        pos += maskBytes;
        if (setPartitioned == 0 || setPartitioned >> expectedSections)
            throw IoError(what + ": invalid set-partitioning flags");
    }
    auto get32 = [&]() -> std::size_t {
        if (p.size() - pos < 4) throw IoError(what + ": truncated brick header");
        std::uint32_t v;
        std::memcpy(&v, p.data() + pos, 4);
        pos += 4;
        return v;
    };
    std::vector<std::size_t> sizes(expectedSections + 1);
    for (auto& s : sizes)
        s = get32();
    ParsedPayload out;
    for (std::size_t i = 0; i <= expectedSections; ++i) {
        if (sizes[i] > p.size() - pos) throw IoError(what + ": section sizes exceed the brick");
        auto span = p.subspan(pos, sizes[i]);
        pos += sizes[i];
        if (i < expectedSections)
            out.sections.push_back(span);
        else
            out.corrections = span;
    }
    if (pos != p.size()) throw IoError(what + ": unexpected bytes after the brick data");
    if (((p[1] & 1) != 0) == out.corrections.empty()) throw IoError(what + ": inconsistent corrections flag");
    out.setPartitioned = setPartitioned;
    return out;
}

} // namespace volcl::codec
