// Motion-field coding: median prediction of vectors, byte planes of differences, one zstd frame.
#include "wavelet/predict/MotionVectorCoding.hpp"

#include "core/Error.hpp"
#include "wavelet/Varint.hpp"

#include <zstd.h>

#include <algorithm>
#include <cstring>

namespace volcl {

namespace {

constexpr std::uint8_t kLayoutForward = 1, kLayoutBidirectional = 2;

// The length of the compressed section: the project's varint.
void putSectionLength(std::vector<std::uint8_t>& out, std::size_t n) {
    putVarint(out, n);
}
bool getSectionLength(std::span<const std::uint8_t> in, std::size_t& pos, std::size_t& n) {
    std::uint64_t v = 0;
    if (getVarint(in, pos, v) != VarintStatus::Ok || v > in.size()) return false;
    n = static_cast<std::size_t>(v);
    return true;
}

// One byte per component: the differences lie in [-128, 127].
std::uint8_t zigzag(int v) {
    return static_cast<std::uint8_t>(zigzagEncode(v));
}
int unzigzag(std::uint8_t u) {
    return static_cast<int>(zigzagDecode(u));
}

bool usesForward(BlockMode m) {
    return m == BlockMode::Forward || m == BlockMode::Bidirectional;
}
bool usesBackward(BlockMode m) {
    return m == BlockMode::Backward || m == BlockMode::Bidirectional;
}

int median3(int a, int b, int c) {
    return std::max(std::min(a, b), std::min(std::max(a, b), c));
}

// Appends the zigzagged differences of the used vectors as three planes (x, y, z).
void putVectors(std::vector<std::uint8_t>& body, const std::vector<MotionVector>& v, Dims blocks,
                const std::vector<bool>& used) {
    std::vector<std::uint8_t> planes[3];
    for (std::size_t b = 0; b < v.size(); ++b) {
        if (!used[b]) continue;
        const MotionVector p = medianPredictor(v, blocks, b);
        const int diff[3] = {v[b].x - p.x, v[b].y - p.y, v[b].z - p.z};
        for (int a = 0; a < 3; ++a) {
            if (diff[a] < -127 || diff[a] > 127) throw DataError("motion vector difference out of range");
            planes[a].push_back(zigzag(diff[a]));
        }
    }
    for (auto& p : planes)
        body.insert(body.end(), p.begin(), p.end());
}

[[noreturn]] void corrupt(std::string_view what, const char* problem) {
    throw IoError(std::string(what) + ": motion field " + problem);
}

} // namespace

MotionVector medianPredictor(const std::vector<MotionVector>& v, Dims blocks, std::size_t b) noexcept {
    const std::size_t x = b % blocks.x, y = (b / blocks.x) % blocks.y, z = b / (blocks.x * blocks.y);
    const MotionVector left = x > 0 ? v[b - 1] : MotionVector{};
    const MotionVector up = y > 0 ? v[b - blocks.x] : MotionVector{};
    const MotionVector front = z > 0 ? v[b - blocks.x * blocks.y] : MotionVector{};
    return {static_cast<std::int16_t>(median3(left.x, up.x, front.x)),
            static_cast<std::int16_t>(median3(left.y, up.y, front.y)),
            static_cast<std::int16_t>(median3(left.z, up.z, front.z))};
}

MotionField canonicalMotionField(const MotionField& field) {
    MotionField f = field;
    for (std::size_t b = 0; b < f.modes.size(); ++b) {
        if (!usesForward(f.modes[b]) && b < f.forward.size()) f.forward[b] = {};
        if (f.bidirectional() && !usesBackward(f.modes[b])) f.backward[b] = {};
        if (f.modes[b] != BlockMode::Intra && b < f.intraValue.size()) f.intraValue[b] = 0;
    }
    return f;
}

std::vector<std::uint8_t> encodeMotionField(const MotionField& field) {
    const std::size_t n = field.grid.count();
    if (field.modes.size() != n || field.forward.size() != n || field.intraValue.size() != n ||
        (field.bidirectional() && field.backward.size() != n))
        throw DataError("motion field: one mode, vector and intra value per block needed");
    const MotionField f = canonicalMotionField(field);
    for (const auto* vs : {&f.forward, &f.backward})
        for (const MotionVector& v : *vs)
            if (std::abs(v.x) > 63 || std::abs(v.y) > 63 || std::abs(v.z) > 63)
                throw DataError("motion field: a vector exceeds 63 half voxels");
    const Dims blocks = f.grid.blocks();
    std::vector<std::uint8_t> body;
    std::vector<bool> fwd(n), bwd(n);
    std::vector<float> intra;
    for (std::size_t b = 0; b < n; ++b) {
        if (!f.bidirectional() && usesBackward(f.modes[b]))
            throw DataError("motion field: a backward mode without backward vectors");
        body.push_back(static_cast<std::uint8_t>(f.modes[b]));
        fwd[b] = usesForward(f.modes[b]);
        bwd[b] = usesBackward(f.modes[b]);
        if (f.modes[b] == BlockMode::Intra) intra.push_back(f.intraValue[b]);
    }
    putVectors(body, f.forward, blocks, fwd);
    if (f.bidirectional()) putVectors(body, f.backward, blocks, bwd);
    for (int byte = 0; byte < 4; ++byte)
        for (float v : intra) {
            std::uint32_t u;
            std::memcpy(&u, &v, 4);
            body.push_back(static_cast<std::uint8_t>(u >> (8 * byte)));
        }
    std::vector<std::uint8_t> packed(ZSTD_compressBound(body.size()));
    const std::size_t z = ZSTD_compress(packed.data(), packed.size(), body.data(), body.size(), 19);
    if (ZSTD_isError(z)) throw Error("motion field: zstd failed");
    std::vector<std::uint8_t> out;
    out.push_back(f.bidirectional() ? kLayoutBidirectional : kLayoutForward);
    putSectionLength(out, z);
    out.insert(out.end(), packed.begin(), packed.begin() + std::ptrdiff_t(z));
    return out;
}

MotionField decodeMotionField(std::span<const std::uint8_t> bytes, BlockGrid grid, std::string_view what) {
    if (bytes.empty()) corrupt(what, "is empty");
    const std::uint8_t layout = bytes[0];
    if (layout != kLayoutForward && layout != kLayoutBidirectional) corrupt(what, "has an unknown layout");
    std::size_t pos = 1, z = 0;
    if (!getSectionLength(bytes, pos, z) || bytes.size() - pos != z)
        corrupt(what, "is truncated or has trailing bytes");
    const std::size_t n = grid.count();
    // Bounded before decompressing: modes, two vector planes of 3 bytes, 4 bytes of intra value per block.
    const unsigned long long declared = ZSTD_getFrameContentSize(bytes.data() + pos, z);
    if (declared == ZSTD_CONTENTSIZE_ERROR || declared == ZSTD_CONTENTSIZE_UNKNOWN || declared > 11 * n)
        corrupt(what, "has a bad compressed section");
    std::vector<std::uint8_t> body(static_cast<std::size_t>(declared));
    const std::size_t got = ZSTD_decompress(body.data(), body.size(), bytes.data() + pos, z);
    if (ZSTD_isError(got) || got != body.size()) corrupt(what, "does not decompress");
    MotionField f;
    f.grid = grid;
    f.modes.resize(n);
    f.forward.assign(n, {});
    if (layout == kLayoutBidirectional) f.backward.assign(n, {});
    f.intraValue.assign(n, 0.0f);
    if (body.size() < n) corrupt(what, "is shorter than its modes");
    std::size_t fwd = 0, bwd = 0, intra = 0;
    for (std::size_t b = 0; b < n; ++b) {
        if (body[b] >= kBlockModeCount) corrupt(what, "has an unknown block mode");
        f.modes[b] = static_cast<BlockMode>(body[b]);
        if (layout == kLayoutForward && usesBackward(f.modes[b]))
            corrupt(what, "uses a missing backward field");
        fwd += usesForward(f.modes[b]);
        bwd += usesBackward(f.modes[b]);
        intra += f.modes[b] == BlockMode::Intra;
    }
    if (body.size() != n + 3 * fwd + 3 * bwd + 4 * intra) corrupt(what, "has the wrong size for its modes");
    const Dims blocks = grid.blocks();
    std::size_t at = n;
    auto getVectors = [&](std::vector<MotionVector>& v, std::size_t used, bool (*uses)(BlockMode)) {
        const std::size_t px = at, py = at + used, pz = at + 2 * used;
        std::size_t k = 0;
        for (std::size_t b = 0; b < n; ++b) {
            if (!uses(f.modes[b])) continue;
            const MotionVector p = medianPredictor(v, blocks, b);
            const int x = p.x + unzigzag(body[px + k]), y = p.y + unzigzag(body[py + k]),
                      zc = p.z + unzigzag(body[pz + k]);
            if (std::abs(x) > 63 || std::abs(y) > 63 || std::abs(zc) > 63)
                corrupt(what, "has a vector out of range");
            v[b] = {std::int16_t(x), std::int16_t(y), std::int16_t(zc)};
            ++k;
        }
        at += 3 * used;
    };
    getVectors(f.forward, fwd, usesForward);
    if (layout == kLayoutBidirectional) getVectors(f.backward, bwd, usesBackward);
    std::size_t k = 0;
    for (std::size_t b = 0; b < n; ++b) {
        if (f.modes[b] != BlockMode::Intra) continue;
        std::uint32_t u = 0;
        for (int byte = 0; byte < 4; ++byte)
            u |= std::uint32_t(body[at + std::size_t(byte) * intra + k]) << (8 * byte);
        std::memcpy(&f.intraValue[b], &u, 4);
        ++k;
    }
    return f;
}

} // namespace volcl
