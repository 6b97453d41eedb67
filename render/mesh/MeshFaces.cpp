// Unique faces of a tet mesh: boundary faces as stored, internal faces once, sorted by area * random priority.
#include "render/mesh/MeshFaces.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_map>

namespace volcl {
namespace {

constexpr std::size_t kLodLevels = 64;

} // namespace

std::size_t MeshFaces::prefixForFraction(double q) const noexcept {
    if (!(q > 0.0)) return boundaryCount; // also NaN
    if (q >= 1.0) return faces.size();
    return boundaryCount + static_cast<std::size_t>(std::llround(q * double(internalCount())));
}

MeshFaces buildMeshFaces(const mesh::TetMesh& mesh, std::uint64_t seed) {
    MeshFaces out;
    out.faces.reserve(mesh.boundaryFaces.size() + mesh.internalFaceCount());
    for (mesh::FaceId f : mesh.boundaryFaces)
        out.faces.push_back({mesh.faceVertices(f), true, f});
    out.boundaryCount = out.faces.size();

    struct Ranked {
        double priority;
        MeshFace face;
    };
    std::vector<Ranked> internal;
    internal.reserve(mesh.internalFaceCount());
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> xi(0.0, 1.0);
    for (std::size_t i = 0; i < mesh.neighbors.size(); ++i) {
        const mesh::FaceId n = mesh.neighbors[i];
        if (n == mesh::kNoFace || n < i) continue; // boundary, or the copy seen from the other tet
        const auto v = mesh.faceVertices(static_cast<mesh::FaceId>(i));
        const auto& a = mesh.points[v[0]];
        const auto& b = mesh.points[v[1]];
        const auto& c = mesh.points[v[2]];
        const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        const double w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        const double cx = u[1] * w[2] - u[2] * w[1], cy = u[2] * w[0] - u[0] * w[2],
                     cz = u[0] * w[1] - u[1] * w[0];
        const double area = 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
        internal.push_back({area * xi(rng), {v, false, static_cast<mesh::FaceId>(i)}});
    }
    // Importance levels: the faces ranked by priority are cut into kLodLevels equal parts, and inside a
    // level they keep mesh order. A prefix is then still (to within one level) the most important faces,
    // while faces next to each other in the array share vertices: the per-frame passes that walk the array
    // (keys, projections) read points in mesh order instead of at random (3x faster on a 1.5 M tet mesh).
    std::vector<std::size_t> rank(internal.size());
    for (std::size_t i = 0; i < rank.size(); ++i)
        rank[i] = i;
    std::stable_sort(rank.begin(), rank.end(), [&](std::size_t x, std::size_t y) {
        return internal[x].priority > internal[y].priority;
    });
    std::vector<std::uint32_t> level(internal.size());
    for (std::size_t r = 0; r < rank.size(); ++r)
        level[rank[r]] = static_cast<std::uint32_t>(r * kLodLevels / rank.size());
    std::vector<std::size_t> byLevel(internal.size());
    for (std::size_t i = 0; i < byLevel.size(); ++i)
        byLevel[i] = i;
    std::stable_sort(byLevel.begin(), byLevel.end(),
                     [&](std::size_t x, std::size_t y) { return level[x] < level[y]; });
    for (std::size_t i : byLevel)
        out.faces.push_back(internal[i].face);
    return out;
}

std::size_t splitLongFaces(MeshFaces& out, const mesh::TetMesh& mesh, double ratio, double budget) {
    const std::size_t base = mesh.points.size();
    auto point = [&](std::uint32_t i) -> const mesh::Point3& {
        return i < base ? mesh.points[i] : out.extraPoints[i - base];
    };
    auto scalar = [&](std::uint32_t i) { return i < base ? mesh.scalars[i] : out.extraScalars[i - base]; };
    auto dist = [&](std::uint32_t i, std::uint32_t j) {
        const auto &a = point(i), &b = point(j);
        return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                         (a[2] - b[2]) * (a[2] - b[2]));
    };
    const std::size_t n = out.faces.size();
    if (n == 0) return 0;
    std::vector<double> longest(n);
    for (std::size_t i = 0; i < n; ++i) {
        const auto& v = out.faces[i].v;
        longest[i] = std::max({dist(v[0], v[1]), dist(v[1], v[2]), dist(v[2], v[0])});
    }
    std::vector<double> sorted = longest;
    std::nth_element(sorted.begin(), sorted.begin() + n / 2, sorted.end());
    const double threshold = ratio * sorted[n / 2];
    std::vector<std::size_t> byLength(n);
    for (std::size_t i = 0; i < n; ++i)
        byLength[i] = i;
    std::sort(byLength.begin(), byLength.end(),
              [&](std::size_t a, std::size_t b) { return longest[a] > longest[b]; });
    // Levels are handed out breadth first: every face over the threshold is cut once (longest first) before
    // any is cut twice, so the budget spreads over the many long faces rather than a few extreme ones.
    std::vector<int> levels(n, 0);
    const double allowed = budget * double(n);
    double added = 0;
    bool full = false;
    for (int level = 1; level <= 3 && !full; ++level)
        for (std::size_t i : byLength) {
            if (!(longest[i] > threshold * std::exp2(level - 1))) break;
            const double extra = 3.0 * std::pow(4.0, level - 1); // one more cut of every piece
            if (added + extra > allowed) {
                full = true;
                break;
            }
            levels[i] = level;
            added += extra;
        }
    if (added == 0) return 0;

    std::unordered_map<std::uint64_t, std::uint32_t> midpoints;
    auto mid = [&](std::uint32_t a, std::uint32_t b) {
        const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
        auto it = midpoints.find(key);
        if (it != midpoints.end()) return it->second;
        const auto &pa = point(a), &pb = point(b);
        const mesh::Point3 m{0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1]), 0.5 * (pa[2] + pb[2])};
        const float s = float(0.5 * (double(scalar(a)) + double(scalar(b))));
        const auto index = static_cast<std::uint32_t>(base + out.extraPoints.size());
        out.extraPoints.push_back(m);
        out.extraScalars.push_back(s);
        out.extraParents.push_back({a, b});
        midpoints.emplace(key, index);
        return index;
    };
    std::vector<MeshFace> faces;
    faces.reserve(n + std::size_t(added));
    std::size_t boundary = 0;
    auto split = [&](auto&& self, std::uint32_t a, std::uint32_t b, std::uint32_t c, bool onBoundary,
                     mesh::FaceId source, int l) -> void {
        if (l == 0) {
            faces.push_back({{a, b, c}, onBoundary, source});
            boundary += onBoundary ? 1 : 0;
            return;
        }
        const std::uint32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
        // The corner pieces and the middle one all keep the face's winding.
        self(self, a, ab, ca, onBoundary, source, l - 1);
        self(self, ab, b, bc, onBoundary, source, l - 1);
        self(self, ca, bc, c, onBoundary, source, l - 1);
        self(self, ab, bc, ca, onBoundary, source, l - 1);
    };
    for (std::size_t i = 0; i < n; ++i) {
        const MeshFace& f = out.faces[i];
        split(split, f.v[0], f.v[1], f.v[2], f.boundary, f.source, levels[i]);
    }
    const std::size_t grown = faces.size() - n;
    out.faces = std::move(faces);
    out.boundaryCount = boundary;
    return grown;
}

} // namespace volcl
