// The cut-border machine's shared state: the border of triangles, vertex adjacency and recency, candidate ranking.
#pragma once

#include "host/mesh/TetMesh.hpp"

#include <array>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

namespace volcl::meshcodec {

inline constexpr std::uint32_t kNoVertex = 0xFFFFFFFFu;
/// Connect candidates beyond this rank are coded as an explicit index (an escape).
inline constexpr std::size_t kMaxCandidates = 48;

/// A triangle of the cut border: its vertices wound outward from the tet that owns it (the processed side),
/// that tet's fourth vertex and its number in emission order.
struct BorderFace {
    std::array<std::uint32_t, 3> v{};
    std::uint32_t opposite = kNoVertex;
    std::uint32_t owner = 0;
    bool alive = true;
};

/// A vertex that a border face may connect to: its score is 4 x the border faces its tet would close
/// (0-3) + the face's vertices it shares an edge with (1-3); and when it last took part in a tet.
inline constexpr unsigned kScores = 16;
struct Candidate {
    std::uint32_t vertex;
    std::uint32_t score;
    std::uint64_t stamp;
    double distance; ///< from the face's predicted fourth vertex (its opposite vertex reflected through it)
};

/// Where a vertex was created: the border face (a, b, c) and that face's opposite vertex p, the inputs of
/// the geometry predictors; kNoVertex in `a` for the vertices of a component's first tet.
struct VertexOrigin {
    std::uint32_t a = kNoVertex, b = kNoVertex, c = kNoVertex, p = kNoVertex;
};

/// The traversal state the encoder and decoder both keep, step for step, from decoded data only: the
/// border (a FIFO of faces, so the region grows breadth first), the glue table (a triangle met from its
/// second side leaves the border), the edges of the tets so far and each vertex's last use.
class CutBorder {
public:
    explicit CutBorder(std::size_t pointCount);

    /// The next live border face in FIFO order, or nullptr when the border is empty (a component is done).
    const BorderFace* popFace();
    /// A new vertex id (the next one) created at `origin`; its position follows through setPosition().
    std::uint32_t newVertex(const VertexOrigin& origin);
    void setPosition(std::uint32_t id, const mesh::Point3& p) { positions_[id] = p; }
    /// Records that face f has no tet beyond it: its vertices lie on the mesh's boundary.
    void markBoundary(const BorderFace& f) {
        for (const std::uint32_t v : f.v)
            boundary_[v] = 1;
    }
    /// How many of face f's vertices lie on a boundary face met so far (0-3).
    unsigned boundaryVertices(const BorderFace& f) const noexcept {
        return unsigned(boundary_[f.v[0]]) + boundary_[f.v[1]] + boundary_[f.v[2]];
    }
    /// Adds tet t (positively oriented when the mesh is consistent). `across`: the border face it was
    /// attached to (t = its vertices + the new one), consumed; nullptr for a component's first tet.
    void addTet(const mesh::Tet& t, const BorderFace* across);
    /// The candidates of face f ranked best first (highest score, then nearest the predicted position,
    /// then most recently used, then highest id), at most kMaxCandidates; excludes f's own vertices and its opposite vertex.
    void rankCandidates(const BorderFace& f, std::vector<Candidate>& out);

    std::size_t vertexCount() const noexcept { return origins_.size(); }
    std::size_t tetCount() const noexcept { return tets_.size(); }
    const std::vector<mesh::Tet>& tets() const noexcept { return tets_; }
    const std::vector<VertexOrigin>& origins() const noexcept { return origins_; }
    std::vector<mesh::Tet> takeTets() { return std::move(tets_); }

private:
    struct Key {
        std::uint32_t a, b, c; // sorted
        bool operator==(const Key&) const = default;
    };
    struct KeyHash {
        std::size_t operator()(const Key& k) const noexcept {
            std::uint64_t h = k.a * 0x9E3779B97F4A7C15ull;
            h ^= (h >> 29) + k.b * 0xBF58476D1CE4E5B9ull;
            h ^= (h >> 31) + k.c * 0x94D049BB133111EBull;
            return static_cast<std::size_t>(h ^ (h >> 32));
        }
    };
    static Key keyOf(std::uint32_t a, std::uint32_t b, std::uint32_t c) noexcept;
    void glueOrAdd(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t opposite,
                   std::uint32_t owner);
    void addEdge(std::uint32_t u, std::uint32_t v);

    std::vector<BorderFace> faces_;
    std::size_t head_ = 0;
    std::unordered_map<Key, std::uint32_t, KeyHash> open_; ///< live border triangles by vertex set
    std::vector<std::vector<std::uint32_t>> adjacency_;    ///< per vertex id, the ids it shares an edge with
    std::vector<std::uint64_t> stamp_;                     ///< per vertex id, the last tet that used it
    std::vector<mesh::Point3> positions_;                  ///< per vertex id, as the decoder sees it
    std::vector<std::uint8_t> boundary_;                   ///< per vertex id, 1 once on a boundary face
    std::vector<std::uint32_t> seen_, count_;              ///< rankCandidates' scratch, per vertex id
    std::uint32_t round_ = 0;
    std::vector<VertexOrigin> origins_;
    std::vector<mesh::Tet> tets_;
};

} // namespace volcl::meshcodec
