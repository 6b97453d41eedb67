// The .vcm container: writing the header and section table, parsing and checking them before decoding.
#include "meshcodec/VcmFormat.hpp"

#include "core/Error.hpp"
#include "core/MemoryBudget.hpp"
#include "host/mesh/TetMesh.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

namespace volcl::meshcodec {

namespace {

static_assert(std::endian::native == std::endian::little,
              "volcl writes little-endian files on little-endian hosts");

// A decision of the adaptive binary coder costs at least log2(4096 / 4065) bits (the model's probabilities
// stay within [31, 4065] / 4096), so a section of s bytes holds at most 8 s / 0.011 < 730 s decisions. Every
// tet takes at least one connectivity decision and every vertex at least 7 geometry decisions (its four
// residual lengths), so counts above these bounds cannot be decoded from the file and are refused first.
constexpr std::uint64_t kMaxDecisionsPerByte = 730;
// Decoder memory per point and per tet (positions, scalars, origins, adjacency, stamps; tets, border faces
// and the glue table), the figure checked against the memory budget.
constexpr std::uint64_t kBytesPerPoint = 160, kBytesPerTet = 200;

// The libFuzzer build defines VOLCL_FUZZ_ACCEPT_ANY_CHECKSUM for this file only (never with the tests or in
// a product build), as for the .vcz reader: a mutated input would almost never get past the checksums.
bool checksumMatches(std::uint64_t stored, std::span<const std::uint8_t> bytes) noexcept {
    const std::uint64_t actual = vczChecksum(bytes);
#ifdef VOLCL_FUZZ_ACCEPT_ANY_CHECKSUM
    (void)stored;
    (void)actual;
    return true;
#else
    return stored == actual;
#endif
}

template <class T> void put(std::vector<std::uint8_t>& out, T v) {
    const std::size_t at = out.size();
    out.resize(at + sizeof(T));
    std::memcpy(out.data() + at, &v, sizeof(T));
}

class FieldReader {
public:
    FieldReader(std::span<const std::uint8_t> in, const std::string& source) : in_(in), source_(source) {}
    template <class T> T get(const char* what) {
        need(sizeof(T), what);
        T v;
        std::memcpy(&v, in_.data() + pos_, sizeof(T));
        pos_ += sizeof(T);
        return v;
    }
    std::string getString(std::size_t n, const char* what) {
        need(n, what);
        std::string s(reinterpret_cast<const char*>(in_.data() + pos_), n);
        pos_ += n;
        return s;
    }
    std::size_t pos() const noexcept { return pos_; }

private:
    void need(std::size_t n, const char* what) const {
        if (in_.size() - pos_ < n)
            throw IoError(source_ + ": truncated .vcm header (" + what + " missing at byte " +
                          std::to_string(pos_) + ")");
    }
    std::span<const std::uint8_t> in_;
    const std::string& source_;
    std::size_t pos_ = 0;
};

} // namespace

bool hasVcmMagic(std::span<const std::uint8_t> bytes) noexcept {
    return bytes.size() >= sizeof(kVcmMagic) && std::memcmp(bytes.data(), kVcmMagic, sizeof(kVcmMagic)) == 0;
}

std::vector<std::uint8_t>
assembleVcm(VcmHeader header, const std::array<std::span<const std::uint8_t>, kVcmSections>& sections) {
    std::vector<std::uint8_t> out(kVcmMagic, kVcmMagic + sizeof(kVcmMagic));
    put<std::uint32_t>(out, kVcmVersion);
    put<std::uint32_t>(out,
                       (header.lossless ? 1u : 0u) | (header.lossless && header.floatPositions ? 2u : 0u));
    put<std::uint8_t>(out, static_cast<std::uint8_t>(header.lossless ? 0 : header.bits));
    put<std::uint8_t>(out, static_cast<std::uint8_t>(header.predictor));
    put<std::uint16_t>(out, 0);
    put<std::uint64_t>(out, header.points);
    put<std::uint64_t>(out, header.tets);
    for (const double v : header.boxMin)
        put<double>(out, v);
    for (const double v : header.boxMax)
        put<double>(out, v);
    put<double>(out, header.valueMin);
    put<double>(out, header.valueMax);
    put<std::uint32_t>(out, static_cast<std::uint32_t>(header.scalarName.size()));
    out.insert(out.end(), header.scalarName.begin(), header.scalarName.end());
    for (const auto& s : sections) {
        put<std::uint64_t>(out, s.size());
        put<std::uint64_t>(out, vczChecksum(s));
    }
    put<std::uint64_t>(out, vczChecksum(out));
    for (const auto& s : sections)
        out.insert(out.end(), s.begin(), s.end());
    return out;
}

VcmView parseVcm(std::span<const std::uint8_t> file, const std::string& source, std::size_t memoryBudget) {
    if (!hasVcmMagic(file)) throw IoError(source + ": not a .vcm file (bad magic)");
    FieldReader r(file.subspan(sizeof(kVcmMagic)), source);
    VcmView view;
    VcmHeader& h = view.header;
    const auto version = r.get<std::uint32_t>("version");
    if (version != kVcmVersion)
        throw IoError(source + ": .vcm version " + std::to_string(version) +
                      " is not supported (this volcl reads " + std::to_string(kVcmVersion) + ")");
    const auto flags = r.get<std::uint32_t>("flags");
    if (flags > 3 || flags == 2) throw IoError(source + ": unknown .vcm flags " + std::to_string(flags));
    h.lossless = (flags & 1) != 0;
    h.floatPositions = (flags & 2) != 0;
    h.bits = r.get<std::uint8_t>("bits");
    const auto predictor = r.get<std::uint8_t>("predictor");
    if (r.get<std::uint16_t>("reserved") != 0)
        throw IoError(source + ": reserved .vcm header field is not zero");
    if (!h.lossless && (h.bits < kMinBits || h.bits > kMaxBits))
        throw IoError(source + ": quantisation bits " + std::to_string(h.bits) + " out of range 1-30");
    if (h.lossless && h.bits != 0) throw IoError(source + ": a lossless .vcm must store 0 quantisation bits");
    if (predictor > 1) throw IoError(source + ": unknown geometry predictor " + std::to_string(predictor));
    h.predictor = static_cast<Predictor>(predictor);
    h.points = r.get<std::uint64_t>("point count");
    h.tets = r.get<std::uint64_t>("tet count");
    for (double& v : h.boxMin)
        v = r.get<double>("box");
    for (double& v : h.boxMax)
        v = r.get<double>("box");
    h.valueMin = r.get<double>("value range");
    h.valueMax = r.get<double>("value range");
    for (int a = 0; a < 3; ++a)
        if (!std::isfinite(h.boxMin[a]) || !std::isfinite(h.boxMax[a]) || h.boxMin[a] > h.boxMax[a])
            throw IoError(source + ": bad quantisation box");
    if (!std::isfinite(h.valueMin) || !std::isfinite(h.valueMax) || h.valueMin > h.valueMax)
        throw IoError(source + ": bad scalar range");
    const auto nameLength = r.get<std::uint32_t>("scalar name length");
    if (nameLength > kMaxScalarName) throw IoError(source + ": scalar name longer than 4096 bytes");
    h.scalarName = r.getString(nameLength, "scalar name");
    std::array<std::uint64_t, kVcmSections> hashes{};
    for (std::size_t s = 0; s < kVcmSections; ++s) {
        h.sectionSize[s] = r.get<std::uint64_t>("section size");
        hashes[s] = r.get<std::uint64_t>("section checksum");
    }
    const std::size_t hashed = sizeof(kVcmMagic) + r.pos();
    const auto headerHash = r.get<std::uint64_t>("header checksum");
    if (!checksumMatches(headerHash, file.first(hashed)))
        throw IoError(source + ": .vcm header checksum mismatch");
    view.headerBytes = sizeof(kVcmMagic) + r.pos();

    std::uint64_t rest = file.size() - view.headerBytes, total = 0;
    for (const std::uint64_t s : h.sectionSize) {
        if (s > rest - total)
            throw IoError(source + ": truncated .vcm (sections run past the end of the file)");
        total += s;
    }
    if (total != rest)
        throw IoError(source + ": " + std::to_string(rest - total) + " bytes after the last .vcm section");
    static const char* const kNames[kVcmSections] = {"connectivity", "connectivity raw bits", "geometry",
                                                     "geometry raw bits"};
    std::size_t at = view.headerBytes;
    for (std::size_t s = 0; s < kVcmSections; ++s) {
        view.sections[s] = file.subspan(at, h.sectionSize[s]);
        at += h.sectionSize[s];
        if (!checksumMatches(hashes[s], view.sections[s]))
            throw IoError(source + ": " + kNames[s] + " section checksum mismatch");
    }

    if (h.tets == 0 || h.points < 4)
        throw IoError(source + ": a .vcm mesh needs at least one tet and 4 points");
    if (h.tets > mesh::kMaxTets) throw IoError(source + ": more tets than volcl supports (2^30 - 1)");
    if (h.points > 4 * h.tets) throw IoError(source + ": more points than the tets can use");
    const std::uint64_t connectivityBytes = h.sectionSize[ConnectivityRans] + h.sectionSize[ConnectivityRaw];
    const std::uint64_t geometryBytes = h.sectionSize[GeometryRans] + h.sectionSize[GeometryRaw];
    if (h.tets > kMaxDecisionsPerByte * (connectivityBytes + 8))
        throw IoError(source + ": " + std::to_string(h.tets) +
                      " tets cannot fit in a connectivity section of " + std::to_string(connectivityBytes) +
                      " bytes");
    if (7 * h.points > kMaxDecisionsPerByte * (geometryBytes + 8))
        throw IoError(source + ": " + std::to_string(h.points) +
                      " points cannot fit in a geometry section of " + std::to_string(geometryBytes) +
                      " bytes");
    checkMemoryBudget(static_cast<std::size_t>(kBytesPerPoint * h.points + kBytesPerTet * h.tets),
                      memoryBudget, source, "decoding the mesh");
    return view;
}

} // namespace volcl::meshcodec
