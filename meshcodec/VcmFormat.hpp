// The .vcm container of a compressed tetrahedral mesh: header, section table, checksums, cost bounds.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace volcl::meshcodec {

inline constexpr std::uint32_t kVcmVersion = 1;
inline constexpr char kVcmMagic[8] = {'V', 'O', 'L', 'C', 'L', 'V', 'C', 'M'};
inline constexpr int kMinBits = 1, kMaxBits = 30; ///< quantisation bits per coordinate and scalar
inline constexpr std::size_t kMaxScalarName = 4096;

/// The sections, in file order: the connectivity's rANS decisions and raw bits, then the geometry's.
enum VcmSection : std::size_t { ConnectivityRans, ConnectivityRaw, GeometryRans, GeometryRaw, kVcmSections };

/// How the geometry predicts a vertex created at a border face (a, b, c) whose processed tet has fourth
/// vertex p: the reflection of p through the face's centroid (2/3 (a + b + c) - p, the tetrahedral
/// parallelogram rule) or the centroid itself.
enum class Predictor : std::uint8_t { Reflect = 0, Average = 1 };

struct VcmHeader {
    bool lossless = false;       ///< float64 positions and float32 scalars kept exactly
    bool floatPositions = false; ///< lossless, and every coordinate is exactly a float32: coded as one
    int bits = 16;               ///< quantisation bits (lossy only)
    Predictor predictor = Predictor::Reflect;
    std::uint64_t points = 0, tets = 0;
    std::array<double, 3> boxMin{}, boxMax{}; ///< the quantisation box (the points' bounds)
    double valueMin = 0, valueMax = 0;        ///< the scalars' quantisation range
    std::string scalarName;
    std::array<std::uint64_t, kVcmSections> sectionSize{};
};

/// The whole file: header (with each section's size and XXH3-64, and the header's own XXH3-64), sections.
std::vector<std::uint8_t>
assembleVcm(VcmHeader header, const std::array<std::span<const std::uint8_t>, kVcmSections>& sections);

struct VcmView {
    VcmHeader header;
    std::array<std::span<const std::uint8_t>, kVcmSections> sections;
    std::size_t headerBytes = 0;
};

/// Parses and checks a whole .vcm file before any decoding: magic, version, field ranges, the section sizes
/// against the file's size (exactly), every checksum, and the counts against the sections' sizes and the
/// memory budget (`memoryBudget`, 0 = the default), so a forged count is refused before allocation. Throws
/// IoError "<source>: ..." naming what is wrong.
VcmView parseVcm(std::span<const std::uint8_t> file, const std::string& source, std::size_t memoryBudget = 0);

/// True when the bytes start with the .vcm magic.
bool hasVcmMagic(std::span<const std::uint8_t> bytes) noexcept;

} // namespace volcl::meshcodec
