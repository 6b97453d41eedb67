// Building a tetrahedral mesh: point merging, degenerate and inverted tets, unused points, face adjacency.
#include "host/mesh/TetMesh.hpp"

#include "core/Error.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace volcl::mesh {

namespace {

Point3 sub(const Point3& a, const Point3& b) noexcept {
    return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}

double det3(const Point3& a, const Point3& b, const Point3& c) noexcept {
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
           a[2] * (b[0] * c[1] - b[1] * c[0]);
}

double length2(const Point3& a) noexcept {
    return a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
}

// 6 * signed volume of (p0, p1, p2, p3).
double orient(const Point3& p0, const Point3& p1, const Point3& p2, const Point3& p3) noexcept {
    return det3(sub(p1, p0), sub(p2, p0), sub(p3, p0));
}

// Longest squared edge of a tet.
double longestEdge2(const std::vector<Point3>& p, const Tet& t) noexcept {
    double m = 0;
    for (int a = 0; a < 4; ++a)
        for (int b = a + 1; b < 4; ++b)
            m = std::max(m, length2(sub(p[t[a]], p[t[b]])));
    return m;
}

void refuseNonFiniteCoordinates(const TetSoup& s, const std::string& source) {
    // Non-finite point values are kept: their tets render with the NaN colour (docs/rendering.md).
    for (std::size_t i = 0; i < s.points.size(); ++i) {
        const Point3& p = s.points[i];
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
            throw DataError(source + ": point " + std::to_string(i) + " has a non-finite coordinate");
    }
}

// Merges points at identical positions; returns the representative (lowest index) of every point.
std::vector<std::uint32_t> mergeDuplicatePoints(TetSoup& s, MeshRepairs& r) {
    const std::size_t n = s.points.size();
    std::vector<std::uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    // -0.0 == +0.0 under operator<, so the comparison merges them.
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
        const Point3& p = s.points[a];
        const Point3& q = s.points[b];
        if (p[0] != q[0]) return p[0] < q[0];
        if (p[1] != q[1]) return p[1] < q[1];
        if (p[2] != q[2]) return p[2] < q[2];
        return a < b;
    });
    std::vector<std::uint32_t> rep(n);
    for (std::size_t i = 0; i < n;) {
        std::size_t j = i + 1;
        while (j < n && s.points[order[j]] == s.points[order[i]])
            ++j;
        const std::uint32_t first = order[i]; // lowest index: ties sort by index
        if (j - i > 1) {
            double sum = 0, lo = INFINITY, hi = -INFINITY;
            for (std::size_t k = i; k < j; ++k) {
                const double v = s.scalars[order[k]];
                sum += v;
                lo = std::min(lo, v);
                hi = std::max(hi, v);
            }
            s.scalars[first] = static_cast<float>(sum / double(j - i));
            if (hi > lo) {
                ++r.mergedScalarConflicts;
                r.mergedScalarMaxDifference = std::max(r.mergedScalarMaxDifference, hi - lo);
            }
            r.mergedPoints += j - i - 1;
        }
        for (std::size_t k = i; k < j; ++k)
            rep[order[k]] = first;
        i = j;
    }
    return rep;
}

struct FaceEntry {
    std::uint64_t key; // the two larger vertex indices
    FaceId face;
    std::uint32_t parity; // 1 when the outward winding is an odd permutation of the sorted vertices
};

// Face adjacency by bucketing every tet face on its smallest vertex (a counting sort), then matching
// the few faces of each bucket on their other two vertices.
void buildAdjacency(TetMesh& m) {
    const std::size_t nt = m.tets.size(), np = m.points.size();
    m.neighbors.assign(4 * nt, kNoFace);
    std::vector<std::uint32_t> start(np + 1, 0);
    auto sortedFace = [&](std::size_t t, unsigned f, std::uint32_t& a, std::uint32_t& b, std::uint32_t& c) {
        const Tet& tet = m.tets[t];
        std::uint32_t v[3] = {tet[kTetFaceVertices[f][0]], tet[kTetFaceVertices[f][1]],
                              tet[kTetFaceVertices[f][2]]};
        std::uint32_t parity = 0;
        if (v[0] > v[1]) std::swap(v[0], v[1]), parity ^= 1;
        if (v[1] > v[2]) std::swap(v[1], v[2]), parity ^= 1;
        if (v[0] > v[1]) std::swap(v[0], v[1]), parity ^= 1;
        a = v[0];
        b = v[1];
        c = v[2];
        return parity;
    };
    for (std::size_t t = 0; t < nt; ++t)
        for (unsigned f = 0; f < 4; ++f) {
            std::uint32_t a, b, c;
            sortedFace(t, f, a, b, c);
            ++start[a + 1];
        }
    for (std::size_t i = 0; i < np; ++i)
        start[i + 1] += start[i];
    std::vector<FaceEntry> entries(4 * nt);
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::size_t t = 0; t < nt; ++t)
        for (unsigned f = 0; f < 4; ++f) {
            std::uint32_t a, b, c;
            const std::uint32_t parity = sortedFace(t, f, a, b, c);
            entries[fill[a]++] = {(std::uint64_t{b} << 32) | c, faceId(t, f), parity};
        }
    for (std::size_t v = 0; v < np; ++v) {
        FaceEntry* first = entries.data() + start[v];
        FaceEntry* last = entries.data() + start[v + 1];
        std::sort(first, last, [](const FaceEntry& x, const FaceEntry& y) {
            return x.key != y.key ? x.key < y.key : x.face < y.face;
        });
        for (FaceEntry* i = first; i < last;) {
            FaceEntry* j = i + 1;
            while (j < last && j->key == i->key)
                ++j;
            if (j - i == 2) {
                if (i[0].parity != i[1].parity) {
                    m.neighbors[i[0].face] = i[1].face;
                    m.neighbors[i[1].face] = i[0].face;
                } else {
                    ++m.repairs.overlappingFaces;
                }
            } else if (j - i > 2) {
                ++m.repairs.nonManifoldFaces;
            }
            i = j;
        }
    }
    m.boundaryFaces.clear();
    for (std::size_t f = 0; f < m.neighbors.size(); ++f)
        if (m.neighbors[f] == kNoFace) m.boundaryFaces.push_back(static_cast<FaceId>(f));
}

} // namespace

double TetMesh::volume(std::size_t t) const noexcept {
    const Tet& k = tets[t];
    return orient(points[k[0]], points[k[1]], points[k[2]], points[k[3]]) / 6.0;
}

double TetMesh::totalVolume() const noexcept {
    double sum = 0;
    for (std::size_t t = 0; t < tets.size(); ++t)
        sum += volume(t);
    return sum;
}

std::array<std::uint32_t, 3> TetMesh::faceVertices(FaceId f) const noexcept {
    const Tet& t = tets[faceTet(f)];
    const auto& l = kTetFaceVertices[faceLocal(f)];
    return {t[l[0]], t[l[1]], t[l[2]]};
}

TetMesh buildTetMesh(TetSoup soup, const std::string& source, const std::string& scalarName) {
    if (soup.scalars.size() != soup.points.size())
        throw Error("internal: buildTetMesh needs one scalar per point");
    if (soup.tets.size() > kMaxTets)
        throw DataError(source + ": " + std::to_string(soup.tets.size()) +
                        " tetrahedra exceed the limit of " + std::to_string(kMaxTets));
    refuseNonFiniteCoordinates(soup, source);
    MeshRepairs r = soup.repairs;
    r.candidateTets = soup.tets.size();

    const std::vector<std::uint32_t> rep = mergeDuplicatePoints(soup, r);

    // Merge, then drop zero-volume tets and re-orient inverted ones.
    std::vector<Tet> kept;
    kept.reserve(soup.tets.size());
    for (const Tet& t0 : soup.tets) {
        Tet t{rep[t0[0]], rep[t0[1]], rep[t0[2]], rep[t0[3]]};
        const bool repeated =
            t[0] == t[1] || t[0] == t[2] || t[0] == t[3] || t[1] == t[2] || t[1] == t[3] || t[2] == t[3];
        if (repeated) {
            ++r.zeroVolumeTets;
            continue;
        }
        const double o = orient(soup.points[t[0]], soup.points[t[1]], soup.points[t[2]], soup.points[t[3]]);
        const double l2 = longestEdge2(soup.points, t);
        if (!(std::abs(o) > 1e-12 * l2 * std::sqrt(l2))) {
            ++r.zeroVolumeTets;
            continue;
        }
        if (o < 0) {
            std::swap(t[1], t[2]);
            ++r.invertedTets;
        }
        kept.push_back(t);
    }
    if (kept.empty())
        throw DataError(source + ": no tetrahedron with a non-zero volume (" +
                        std::to_string(r.candidateTets) + " candidates, " + std::to_string(r.zeroVolumeTets) +
                        " of zero volume)");

    // Remove unused points (merged duplicates are never used: tets refer to representatives).
    std::vector<std::uint32_t> newIndex(soup.points.size(), 0xFFFFFFFFu);
    for (const Tet& t : kept)
        for (std::uint32_t v : t)
            newIndex[v] = 0;
    TetMesh m;
    std::size_t next = 0;
    for (std::size_t i = 0; i < soup.points.size(); ++i) {
        if (newIndex[i] == 0xFFFFFFFFu) {
            if (rep[i] == i) ++r.unusedPoints;
            continue;
        }
        newIndex[i] = static_cast<std::uint32_t>(next++);
    }
    m.points.reserve(next);
    m.scalars.reserve(next);
    for (std::size_t i = 0; i < soup.points.size(); ++i)
        if (newIndex[i] != 0xFFFFFFFFu) {
            m.points.push_back(soup.points[i]);
            m.scalars.push_back(soup.scalars[i]);
        }
    soup.points = {};
    soup.scalars = {};
    for (Tet& t : kept)
        for (std::uint32_t& v : t)
            v = newIndex[v];
    m.tets = std::move(kept);
    m.repairs = r;
    m.scalarName = scalarName;

    buildAdjacency(m);

    m.boundsMin = m.boundsMax = m.points[0];
    for (const Point3& p : m.points)
        for (int a = 0; a < 3; ++a) {
            m.boundsMin[a] = std::min(m.boundsMin[a], p[a]);
            m.boundsMax[a] = std::max(m.boundsMax[a], p[a]);
        }
    // The value range is over finite values (NaN/Inf have no place on a transfer function's axis).
    float lo = INFINITY, hi = -INFINITY;
    for (float v : m.scalars)
        if (std::isfinite(v)) {
            lo = std::min(lo, v);
            hi = std::max(hi, v);
        }
    m.valueMin = lo <= hi ? lo : 0.0f;
    m.valueMax = lo <= hi ? hi : 0.0f;
    double e2 = 0;
    for (const Tet& t : m.tets)
        e2 = std::max(e2, longestEdge2(m.points, t));
    m.maxEdgeLength = std::sqrt(e2);
    return m;
}

} // namespace volcl::mesh
