// Tetrahedral mesh compression: the connectivity traversal and the geometry coding, each one template that
// encodes and decodes, the quantisation, and the .vcm reading and writing around them.
#include "meshcodec/MeshCodec.hpp"

#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "meshcodec/CutBorder.hpp"
#include "meshcodec/SymbolCoder.hpp"
#include "wavelet/Varint.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <deque>
#include <fstream>
#include <limits>

namespace volcl::meshcodec {

namespace {

using mesh::Tet;
using mesh::TetMesh;

// ------------------------------------------------------------------------------ geometry

constexpr int kChannels = 4; // x, y, z, scalar
constexpr int kLengthContexts = 24;
constexpr int kLengthNodes = 128; // residual lengths 0-64 as 7-bit binary trees
struct GeometryModels {
    BitModel length[kChannels][kLengthContexts][kLengthNodes];
    BitModel second[kChannels][65]; ///< the bit below the leading one, per length
    unsigned previous[kChannels] = {};
};

/// A residual (zigzagged): its bit length through an adaptive binary tree, then the bit below its leading
/// one adaptively, the rest raw. The length's context is the channel's previous length.
template <class Side>
std::uint64_t codeResidual(Side& side, GeometryModels& m, int ch, std::uint64_t zig,
                           const std::string& source) {
    const unsigned want = static_cast<unsigned>(std::bit_width(zig));
    const unsigned context = m.previous[ch];
    BitModel* tree = m.length[ch][std::min<unsigned>(context, kLengthContexts - 1)];
    unsigned node = 1;
    for (int b = 6; b >= 0; --b)
        node = 2 * node + side.bit(tree[node], (want >> b) & 1u);
    const unsigned length = node - kLengthNodes;
    if (length > 64) throw IoError(source + ": corrupt .vcm geometry (residual longer than 64 bits)");
    m.previous[ch] = length;
    if (length == 0) return 0;
    if (length == 1) return 1;
    const std::uint64_t lead = std::uint64_t(1) << (length - 1), half = lead >> 1;
    const std::uint64_t second = side.bit(m.second[ch][length], (zig & half) ? 1u : 0u) ? half : 0;
    return lead | second | (side.raw(static_cast<int>(length - 2), zig) & (half - 1));
}

/// Values as integer codes in which a prediction is made and a residual taken: quantisation indices, or
/// the order-preserving bit patterns of float64 (positions) or float32 (scalars, and positions that are all
/// exactly floats) when lossless.
struct QuantisedDomain {
    std::int64_t maxQ;
    std::uint64_t predict(const std::uint64_t* v, const VertexOrigin& o, std::uint32_t id,
                          Predictor p) const {
        if (o.a == kNoVertex) return id > 0 ? v[id - 1] : static_cast<std::uint64_t>((maxQ + 1) / 2);
        const auto a = static_cast<std::int64_t>(v[o.a]), b = static_cast<std::int64_t>(v[o.b]),
                   c = static_cast<std::int64_t>(v[o.c]);
        if (p == Predictor::Average) return static_cast<std::uint64_t>((a + b + c + 1) / 3);
        const std::int64_t num = 2 * (a + b + c) - 3 * static_cast<std::int64_t>(v[o.p]);
        const std::int64_t q = num >= 0 ? (num + 1) / 3 : -((-num + 1) / 3);
        return static_cast<std::uint64_t>(std::clamp<std::int64_t>(q, 0, maxQ));
    }
    static constexpr int kWidth = 64;
};

template <class F, class U> struct FloatDomain {
    static constexpr int kWidth = 8 * sizeof(U);
    static U toCode(F x) noexcept {
        const U b = std::bit_cast<U>(x);
        return b >> (kWidth - 1) ? ~b : b | (U(1) << (kWidth - 1));
    }
    static F fromCode(U c) noexcept {
        return std::bit_cast<F>(c >> (kWidth - 1) ? c & ~(U(1) << (kWidth - 1)) : ~c);
    }
    std::uint64_t predict(const std::uint64_t* v, const VertexOrigin& o, std::uint32_t id,
                          Predictor p) const {
        if (o.a == kNoVertex) return id > 0 ? v[id - 1] : toCode(F(0));
        const double a = fromCode(U(v[o.a])), b = fromCode(U(v[o.b])), c = fromCode(U(v[o.c]));
        const double guess =
            p == Predictor::Average ? (a + b + c) / 3.0 : (2.0 * (a + b + c)) / 3.0 - fromCode(U(v[o.p]));
        const F g = static_cast<F>(guess);
        return toCode(std::isfinite(g) ? g : F(0));
    }
};

std::uint64_t signExtend(std::uint64_t r, int width) noexcept {
    if (width == 64) return r;
    const std::uint64_t sign = std::uint64_t(1) << (width - 1), mask = (sign << 1) - 1;
    r &= mask;
    return (r ^ sign) - sign;
}

/// Codes channel values (per vertex, the four channels in turn) in decoded vertex order. Encoding reads
/// `codes`; decoding fills them.
double stepOf(double lo, double hi, int bits) noexcept {
    return (hi - lo) / static_cast<double>((std::uint64_t(1) << bits) - 1);
}
std::uint64_t quantise(double x, double lo, double step, std::int64_t maxQ) noexcept {
    if (!(step > 0)) return 0;
    return static_cast<std::uint64_t>(std::clamp<std::int64_t>(std::llround((x - lo) / step), 0, maxQ));
}

using PositionCodes = FloatDomain<double, std::uint64_t>;
using ScalarCodes = FloatDomain<float, std::uint32_t>;

/// Codes one vertex's channels (x, y, z, scalar) at a time, when the cut border creates it: the decoder then
/// knows its position for ranking the next candidates. Encoding reads `codes`; decoding fills them.
template <class Side> class GeometryCoder {
public:
    GeometryCoder(Side& side, const VcmHeader& h, std::size_t points, const std::string& source)
        : side_(side), h_(h), q_{h.lossless ? 0 : (std::int64_t(1) << h.bits) - 1}, source_(source),
          models_(std::make_unique<GeometryModels>()) {
        for (auto& c : codes)
            c.assign(points, 0);
        for (int a = 0; a < 3; ++a)
            step_[a] = h.lossless ? 0 : stepOf(h.boxMin[a], h.boxMax[a], h.bits);
        step_[3] = h.lossless ? 0 : stepOf(h.valueMin, h.valueMax, h.bits);
    }
    void code(std::uint32_t id, const VertexOrigin& o) {
        for (int ch = 0; ch < kChannels; ++ch) {
            std::vector<std::uint64_t>& v = codes[ch];
            const bool lossless = h_.lossless, asDouble = lossless && ch < 3 && !h_.floatPositions;
            const int width = !lossless ? 64 : asDouble ? PositionCodes::kWidth : ScalarCodes::kWidth;
            const std::uint64_t pred = !lossless  ? q_.predict(v.data(), o, id, h_.predictor)
                                       : asDouble ? PositionCodes{}.predict(v.data(), o, id, h_.predictor)
                                                  : ScalarCodes{}.predict(v.data(), o, id, h_.predictor);
            const std::uint64_t r = Side::kDecoding ? 0 : signExtend(v[id] - pred, width);
            const std::uint64_t zig =
                codeResidual(side_, *models_, ch, zigzagEncode(static_cast<std::int64_t>(r)), source_);
            if constexpr (Side::kDecoding) {
                const std::uint64_t sum = pred + static_cast<std::uint64_t>(zigzagDecode(zig));
                v[id] = width == 64 ? sum : sum & ((std::uint64_t(1) << (width & 63)) - 1);
                if (!lossless && v[id] > static_cast<std::uint64_t>(q_.maxQ))
                    throw IoError(source_ +
                                  ": corrupt .vcm geometry (a value outside its quantisation range)");
            }
        }
    }
    /// The decoded position of vertex id (dequantised).
    mesh::Point3 position(std::uint32_t id) const noexcept {
        mesh::Point3 p;
        for (int a = 0; a < 3; ++a)
            p[a] = h_.floatPositions ? double(ScalarCodes::fromCode(static_cast<std::uint32_t>(codes[a][id])))
                   : h_.lossless     ? PositionCodes::fromCode(codes[a][id])
                                     : h_.boxMin[a] + static_cast<double>(codes[a][id]) * step_[a];
        return p;
    }
    float scalar(std::uint32_t id) const noexcept {
        return h_.lossless ? ScalarCodes::fromCode(static_cast<std::uint32_t>(codes[3][id]))
                           : static_cast<float>(h_.valueMin + static_cast<double>(codes[3][id]) * step_[3]);
    }
    std::array<std::vector<std::uint64_t>, kChannels> codes;

private:
    Side& side_;
    const VcmHeader& h_;
    QuantisedDomain q_;
    const std::string& source_;
    std::unique_ptr<GeometryModels> models_;
    double step_[kChannels] = {};
};

// ------------------------------------------------------------------------------ connectivity

enum class Op : std::uint8_t { Connect, New, Border };
struct Decision {
    Op op = Op::Border;
    std::uint32_t vertex = kNoVertex; ///< Connect: the decoded id of the tet's fourth vertex
};

// Operation contexts: the best candidate's score (0-15), whether a second candidate has it too, and how
// many of the face's vertices lie on boundary faces met so far (0-3).
constexpr int kOpContexts = 2 * kScores * 4;
constexpr int kRankPositions = 8;
struct ConnectivityModels {
    BitModel op[kOpContexts][2];            ///< [context][0: connect or not, 1: new vertex or border]
    BitModel rank[kScores][kRankPositions]; ///< [candidate's score][rank, capped]: "this candidate"
    BitModel seedNew;                       ///< a first tet's vertex is new (else an explicit index)
};

int bitsFor(std::size_t n) noexcept { // bits of an index below n
    int b = 0;
    while ((std::size_t(1) << b) < n)
        ++b;
    return b;
}

[[noreturn]] void corrupt(const std::string& source, const std::string& what) {
    throw IoError(source + ": corrupt .vcm connectivity (" + what + ")");
}

/// What the decoder learns from the stream, the encoder learns from the mesh: the truth at each step.
/// The decoder's Truth knows nothing (its answers are ignored by SymbolDecoder).
struct NoTruth {
    std::array<std::uint32_t, 4> seed() { return {kNoVertex, kNoVertex, kNoVertex, kNoVertex}; }
    Decision atFace(const BorderFace&) { return {}; }
    void vertexCreated(std::uint32_t, std::array<std::vector<std::uint64_t>, kChannels>&) {}
    void tetAdded() {}
};

/// The encoder's truth: the mesh, the decoded id of each of its points (kNoVertex until met), which tets
/// are emitted, and the tet and points the current step adds.
class MeshTruth {
public:
    /// `pointCodes`: per channel, each mesh point's code (quantised or the float's bits).
    MeshTruth(const TetMesh& m, const std::array<std::vector<std::uint64_t>, kChannels>& pointCodes)
        : newIndex(m.pointCount(), kNoVertex), mesh_(m), pointCodes_(pointCodes),
          processed_(m.tetCount(), 0) {}
    std::array<std::uint32_t, 4> seed() {
        while (processed_[scan_])
            ++scan_;
        pendingTet_ = scan_;
        std::array<std::uint32_t, 4> want{};
        for (int k = 0; k < 4; ++k) {
            const std::uint32_t p = mesh_.tets[scan_][k];
            want[k] = newIndex[p];
            if (want[k] == kNoVertex) pendingPoints_.push_back(p);
        }
        return want;
    }
    Decision atFace(const BorderFace& f) {
        const Tet& owner = mesh_.tets[emitted_[f.owner]];
        unsigned local = 0;
        while (newIndex[owner[local]] != f.opposite)
            ++local;
        const mesh::FaceId nb = mesh_.neighbors[mesh::faceId(emitted_[f.owner], local)];
        if (nb == mesh::kNoFace || processed_[mesh::faceTet(nb)]) return {Op::Border, kNoVertex};
        pendingTet_ = mesh::faceTet(nb);
        const std::uint32_t w = mesh_.tets[pendingTet_][mesh::faceLocal(nb)];
        if (newIndex[w] != kNoVertex) return {Op::Connect, newIndex[w]};
        pendingPoints_.push_back(w);
        return {Op::New, kNoVertex};
    }
    void vertexCreated(std::uint32_t id, std::array<std::vector<std::uint64_t>, kChannels>& codes) {
        const std::uint32_t point = pendingPoints_.front();
        pendingPoints_.pop_front();
        newIndex[point] = id;
        for (int ch = 0; ch < kChannels; ++ch)
            codes[ch][id] = pointCodes_[ch][point];
    }
    void tetAdded() {
        processed_[pendingTet_] = 1;
        emitted_.push_back(static_cast<std::uint32_t>(pendingTet_));
    }

    std::vector<std::uint32_t> newIndex; ///< per mesh point, its decoded id

private:
    const TetMesh& mesh_;
    const std::array<std::vector<std::uint64_t>, kChannels>& pointCodes_;
    std::vector<std::uint8_t> processed_;
    std::vector<std::uint32_t> emitted_; ///< per emitted tet, the mesh tet
    std::deque<std::uint32_t> pendingPoints_;
    std::size_t scan_ = 0, pendingTet_ = 0;
};

/// The cut-border machine: grows a region tet by tet over the border's faces in FIFO order. At each face
/// the tet on its outer side is coded as "connect" (its fourth vertex is already known: its rank among the
/// ranked candidates, or an escape and an explicit index), "new vertex" or "border" (no tet there). An empty
/// border starts a new component with an explicit tet. Stops once `tetCount` tets are out: faces still on
/// the border then need no code. A vertex's geometry is coded when it is created (`geometry`), so that
/// candidates can be ranked by position.
template <class Side, class GeometrySide, class Truth>
void codeConnectivity(Side& side, GeometryCoder<GeometrySide>& geometry, Truth& truth, CutBorder& cb,
                      std::uint64_t tetCount, std::uint64_t pointCount, const std::string& source) {
    ConnectivityModels m;
    std::vector<Candidate> cands;
    const auto explicitVertex = [&](std::uint32_t want) {
        const std::size_t n = cb.vertexCount();
        if (n == 0) corrupt(source, "a vertex index before any vertex");
        const std::uint64_t v = side.raw(bitsFor(n), want);
        if (v >= n) corrupt(source, "vertex index out of range");
        return static_cast<std::uint32_t>(v);
    };
    const auto createVertex = [&](const VertexOrigin& o) {
        if (cb.vertexCount() >= pointCount) corrupt(source, "more vertices than the header's count");
        const std::uint32_t id = cb.newVertex(o);
        truth.vertexCreated(id, geometry.codes);
        geometry.code(id, o);
        cb.setPosition(id, geometry.position(id));
        return id;
    };
    while (cb.tetCount() < tetCount) {
        const BorderFace* f = cb.popFace();
        if (!f) { // a new component: its first tet explicitly
            const std::array<std::uint32_t, 4> want = truth.seed();
            Tet t{};
            for (int k = 0; k < 4; ++k)
                t[k] = side.bit(m.seedNew, want[k] == kNoVertex ? 1u : 0u) ? createVertex({})
                                                                           : explicitVertex(want[k]);
            for (int i = 0; i < 4; ++i)
                for (int j = i + 1; j < 4; ++j)
                    if (t[i] == t[j]) corrupt(source, "a tet with a repeated vertex");
            cb.addTet(t, nullptr);
            truth.tetAdded();
            continue;
        }
        cb.rankCandidates(*f, cands);
        const Decision d = truth.atFace(*f);
        const unsigned best = cands.empty() ? 0 : cands[0].score;
        const unsigned ctx =
            (2 * best + (cands.size() > 1 && cands[1].score == best ? 1u : 0u)) * 4 + cb.boundaryVertices(*f);
        if (side.bit(m.op[ctx][0], d.op == Op::Connect ? 1u : 0u)) {
            std::uint32_t v = kNoVertex;
            for (std::size_t i = 0; i < cands.size() && v == kNoVertex; ++i)
                if (side.bit(m.rank[cands[i].score][std::min<std::size_t>(i, kRankPositions - 1)],
                             cands[i].vertex == d.vertex ? 1u : 0u))
                    v = cands[i].vertex;
            if (v == kNoVertex) v = explicitVertex(d.vertex);
            if (v == f->v[0] || v == f->v[1] || v == f->v[2]) corrupt(source, "a tet with a repeated vertex");
            cb.addTet({f->v[0], f->v[1], f->v[2], v}, f);
            truth.tetAdded();
        } else if (side.bit(m.op[ctx][1], d.op == Op::New ? 1u : 0u)) {
            const std::uint32_t v = createVertex({f->v[0], f->v[1], f->v[2], f->opposite});
            cb.addTet({f->v[0], f->v[1], f->v[2], v}, f);
            truth.tetAdded();
        } else { // border: the face leaves the border
            cb.markBoundary(*f);
        }
    }
    if (cb.vertexCount() != pointCount) corrupt(source, "fewer vertices than the header's count");
}

} // namespace

double quantisationBound(const VcmHeader& h, int axis) noexcept {
    if (h.lossless) return 0;
    const double lo = axis < 3 ? h.boxMin[axis] : h.valueMin, hi = axis < 3 ? h.boxMax[axis] : h.valueMax;
    return stepOf(lo, hi, h.bits) / 2;
}

EncodedMesh encodeMesh(const TetMesh& mesh, const VcmOptions& options) {
    if (!options.lossless && (options.bits < kMinBits || options.bits > kMaxBits))
        throw UsageError("--bits " + std::to_string(options.bits) + " is out of range 1-30");
    if (mesh.tetCount() == 0) throw DataError("an empty mesh cannot be encoded");
    if (mesh.scalars.size() != mesh.pointCount() || mesh.neighbors.size() != 4 * mesh.tetCount())
        throw Error("internal: encodeMesh needs a built TetMesh");
    VcmHeader h;
    h.lossless = options.lossless;
    h.bits = options.lossless ? 0 : options.bits;
    h.floatPositions =
        options.lossless && std::all_of(mesh.points.begin(), mesh.points.end(), [](const mesh::Point3& p) {
            return std::all_of(p.begin(), p.end(), [](double c) {
                return std::bit_cast<std::uint64_t>(double(float(c))) == std::bit_cast<std::uint64_t>(c);
            });
        });
    h.points = mesh.pointCount();
    h.tets = mesh.tetCount();
    h.scalarName = mesh.scalarName.substr(0, kMaxScalarName);
    h.boxMin = mesh.points[0];
    h.boxMax = mesh.points[0];
    for (const mesh::Point3& p : mesh.points)
        for (int a = 0; a < 3; ++a) {
            h.boxMin[a] = std::min(h.boxMin[a], p[a]);
            h.boxMax[a] = std::max(h.boxMax[a], p[a]);
        }
    const auto [lo, hi] = std::minmax_element(mesh.scalars.begin(), mesh.scalars.end());
    h.valueMin = *lo;
    h.valueMax = *hi;

    // Each point's channel codes.
    std::array<std::vector<std::uint64_t>, kChannels> pointCodes;
    const std::int64_t maxQ = options.lossless ? 0 : (std::int64_t(1) << h.bits) - 1;
    for (int ch = 0; ch < kChannels; ++ch) {
        pointCodes[ch].resize(mesh.pointCount());
        const double lo = ch < 3 ? h.boxMin[ch] : h.valueMin, hi = ch < 3 ? h.boxMax[ch] : h.valueMax;
        const double step = options.lossless ? 0 : stepOf(lo, hi, h.bits);
        for (std::size_t i = 0; i < mesh.pointCount(); ++i) {
            const double x = ch < 3 ? mesh.points[i][ch] : mesh.scalars[i];
            pointCodes[ch][i] = !options.lossless             ? quantise(x, lo, step, maxQ)
                                : ch < 3 && !h.floatPositions ? PositionCodes::toCode(x)
                                : ch < 3                      ? ScalarCodes::toCode(static_cast<float>(x))
                                                              : ScalarCodes::toCode(mesh.scalars[i]);
        }
    }
    // The traversal with the reflection predictor; the centroid predictor is then tried on the same
    // vertices (geometry depends only on each vertex's origin and the vertices before it, and the
    // connectivity's ranking only on decoded positions, which both predictors reproduce exactly). The
    // smaller geometry is kept.
    std::array<std::vector<std::uint8_t>, kVcmSections> sections;
    h.predictor = Predictor::Reflect;
    SymbolEncoder connectivity, geometrySide;
    GeometryCoder<SymbolEncoder> geometry(geometrySide, h, mesh.pointCount(), "encoder");
    MeshTruth truth(mesh, pointCodes);
    CutBorder cb(mesh.pointCount());
    codeConnectivity(connectivity, geometry, truth, cb, h.tets, h.points, "encoder");
    connectivity.finish(sections[ConnectivityRans], sections[ConnectivityRaw]);
    geometrySide.finish(sections[GeometryRans], sections[GeometryRaw]);
    {
        VcmHeader centroid = h;
        centroid.predictor = Predictor::Average;
        SymbolEncoder side;
        GeometryCoder<SymbolEncoder> other(side, centroid, mesh.pointCount(), "encoder");
        other.codes = geometry.codes;
        const std::vector<VertexOrigin>& origins = cb.origins();
        for (std::uint32_t id = 0; id < origins.size(); ++id)
            other.code(id, origins[id]);
        std::vector<std::uint8_t> rans, raw;
        side.finish(rans, raw);
        if (rans.size() + raw.size() < sections[GeometryRans].size() + sections[GeometryRaw].size()) {
            h.predictor = Predictor::Average;
            sections[GeometryRans] = std::move(rans);
            sections[GeometryRaw] = std::move(raw);
        }
    }
    std::vector<std::uint32_t> newIndex = std::move(truth.newIndex);
    EncodedMesh out;
    out.bytes = assembleVcm(h, {sections[0], sections[1], sections[2], sections[3]});
    out.newIndex = std::move(newIndex);
    for (std::size_t s = 0; s < kVcmSections; ++s)
        h.sectionSize[s] = sections[s].size();
    out.headerBytes = out.bytes.size() -
                      (sections[0].size() + sections[1].size() + sections[2].size() + sections[3].size());
    out.header = std::move(h);
    return out;
}

DecodedMesh decodeMesh(std::span<const std::uint8_t> file, const std::string& source,
                       std::size_t memoryBudget) {
    const VcmView view = parseVcm(file, source, memoryBudget);
    const VcmHeader& h = view.header;
    DecodedMesh out;
    out.header = h;
    const auto n = static_cast<std::size_t>(h.points);
    CutBorder cb(n);
    SymbolDecoder connectivity(view.sections[ConnectivityRans], view.sections[ConnectivityRaw]);
    SymbolDecoder geometrySide(view.sections[GeometryRans], view.sections[GeometryRaw]);
    GeometryCoder<SymbolDecoder> geometry(geometrySide, h, n, source);
    NoTruth none;
    codeConnectivity(connectivity, geometry, none, cb, h.tets, h.points, source);
    if (!connectivity.exact()) corrupt(source, "the streams do not end where the tets do");
    if (!geometrySide.exact())
        throw IoError(source + ": corrupt .vcm geometry (the streams do not end with the points)");
    out.points.resize(n);
    out.scalars.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
        out.points[i] = geometry.position(static_cast<std::uint32_t>(i));
        out.scalars[i] = geometry.scalar(static_cast<std::uint32_t>(i));
    }
    out.tets = cb.takeTets();
    return out;
}

bool isVcmFile(const std::filesystem::path& path) {
    // Only regular files are opened: a FIFO would block the read, /dev/zero never ends.
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) return false;
    std::ifstream in(path, std::ios::binary);
    std::uint8_t magic[sizeof(kVcmMagic)] = {};
    if (!in.read(reinterpret_cast<char*>(magic), sizeof(magic))) return false;
    return hasVcmMagic(magic);
}

TetMesh readVcm(const std::filesystem::path& path, const mesh::MeshReadOptions& options) {
    const std::vector<std::byte> bytes = readFileBytes(path);
    const std::string source = path.string();
    DecodedMesh d = decodeMesh({reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()}, source);
    if (options.array && *options.array != d.header.scalarName)
        throw DataError(source + ": no array named '" + *options.array + "'; arrays: '" +
                        d.header.scalarName + "' (point)");
    mesh::TetSoup soup;
    soup.repairs.inputPoints = d.points.size();
    soup.repairs.inputCells = d.tets.size();
    soup.points = std::move(d.points);
    soup.scalars = std::move(d.scalars);
    soup.tets = std::move(d.tets);
    TetMesh m = mesh::buildTetMesh(std::move(soup), source, d.header.scalarName);
    m.format = d.header.lossless ? "volcl .vcm (lossless)"
                                 : "volcl .vcm (" + std::to_string(d.header.bits) + " bits)";
    m.arrays = {{d.header.scalarName, true, 1, d.header.lossless ? "Float32" : "quantised"}};
    return m;
}

bool isMeshFile(const std::filesystem::path& path) {
    return isVcmFile(path) || mesh::detectMeshFormat(path).has_value();
}

TetMesh readAnyMesh(const std::filesystem::path& path, const mesh::MeshReadOptions& options) {
    if (isVcmFile(path)) return readVcm(path, options);
    return mesh::readMesh(path, options);
}

EncodedMesh writeVcm(const TetMesh& mesh, const std::filesystem::path& path, const VcmOptions& options) {
    checkOutputPath(path);
    EncodedMesh e = encodeMesh(mesh, options);
    AtomicFile out(path);
    out.write({reinterpret_cast<const std::byte*>(e.bytes.data()), e.bytes.size()});
    out.commit();
    return e;
}

} // namespace volcl::meshcodec
