// Per-tet linear fields, face planes and the boundary-face BVH with its ray query (double precision).
#include "render/mesh/MeshGeometry.hpp"

#include "core/runtime/ParallelFor.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <numeric>

namespace volcl::mesh_detail {

TetField tetField(const mesh::TetMesh& m, std::size_t tet) {
    const auto& v = m.tets[tet];
    return tetFieldOf(m, tet, {m.scalars[v[0]], m.scalars[v[1]], m.scalars[v[2]], m.scalars[v[3]]});
}

TetField tetFieldOf(const mesh::TetMesh& m, std::size_t tet, const std::array<double, 4>& values) {
    const auto& v = m.tets[tet];
    const Vec3 p0 = m.points[v[0]];
    const Vec3 e1 = sub(m.points[v[1]], p0), e2 = sub(m.points[v[2]], p0), e3 = sub(m.points[v[3]], p0);
    const double s0 = values[0];
    const double d1 = values[1] - s0, d2 = values[2] - s0, d3 = values[3] - s0;
    // Solve [e1; e2; e3] g = (d1, d2, d3) by Cramer's rule: g = (d1 (e2 x e3) + d2 (e3 x e1) + d3 (e1 x e2))
    // / det.
    const double det = dot(e1, cross(e2, e3));
    TetField f;
    f.p0 = p0;
    f.value = s0;
    if (det != 0.0)
        f.gradient =
            scale(add(add(scale(cross(e2, e3), d1), scale(cross(e3, e1), d2)), scale(cross(e1, e2), d3)),
                  1.0 / det);
    return f;
}

FacePlane facePlane(const mesh::TetMesh& m, mesh::FaceId f) {
    const auto v = m.faceVertices(f);
    const Vec3 a = m.points[v[0]], b = m.points[v[1]], c = m.points[v[2]];
    return {cross(sub(b, a), sub(c, a)), a};
}

NormalisedTet normalisedTet(const mesh::TetMesh& m, std::size_t t, const Vec3& centre, double scale_) {
    NormalisedTet r;
    const double inv = 1.0 / scale_;
    auto normalise = [&](const Vec3& p) { return scale(sub(p, centre), inv); };
    for (unsigned f = 0; f < 4; ++f) {
        const mesh::FaceId id = mesh::faceId(t, f), nb = m.neighbors[id];
        const mesh::FaceId canon = nb != mesh::kNoFace && nb < id ? nb : id;
        const auto v = m.faceVertices(canon);
        const Vec3 a = normalise(m.points[v[0]]), b = normalise(m.points[v[1]]),
                   c = normalise(m.points[v[2]]);
        Vec3 n = normalized(cross(sub(b, a), sub(c, a)));
        double w = -dot(n, a);
        if (canon != id) {
            n = scale(n, -1.0);
            w = -w;
        }
        r.normal[f] = n;
        r.offset[f] = w;
    }
    for (const auto v : m.tets[t])
        r.finite = r.finite && std::isfinite(m.scalars[v]);
    if (!r.finite) {
        r.gradient = {NAN, NAN, NAN};
        r.value = NAN;
        return r;
    }
    // s(x') = value + g . (centre + scale x' - p0) = (value + g . (centre - p0)) + (scale g) . x'
    const TetField fd = tetField(m, t);
    r.gradient = scale(fd.gradient, scale_);
    r.value = fd.value + dot(fd.gradient, sub(centre, fd.p0));
    return r;
}

namespace {

struct BvhBuilder {
    std::vector<Vec3> lo, hi, centre;
    std::vector<std::uint32_t> order;
    BoundaryBvh& bvh;

    /// Builds the subtree over order[begin, end) at node index `at` (depth-first: its left child is next).
    void build(std::uint32_t at, std::uint32_t begin, std::uint32_t end) {
        BvhNode node;
        const double inf = std::numeric_limits<double>::infinity();
        node.lo = {inf, inf, inf};
        node.hi = {-inf, -inf, -inf};
        Vec3 clo = node.lo, chi = node.hi;
        for (std::uint32_t i = begin; i < end; ++i)
            for (int a = 0; a < 3; ++a) {
                node.lo[a] = std::min(node.lo[a], lo[order[i]][a]);
                node.hi[a] = std::max(node.hi[a], hi[order[i]][a]);
                clo[a] = std::min(clo[a], centre[order[i]][a]);
                chi[a] = std::max(chi[a], centre[order[i]][a]);
            }
        const std::uint32_t count = end - begin;
        if (count <= 4) {
            node.first = begin;
            node.count = count;
            bvh.nodes[at] = node;
            return;
        }
        const double ex = chi[0] - clo[0], ey = chi[1] - clo[1], ez = chi[2] - clo[2];
        const int axis = ex >= ey && ex >= ez ? 0 : ey >= ez ? 1 : 2;
        const std::uint32_t mid = begin + count / 2;
        std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                         [&](std::uint32_t x, std::uint32_t y) { return centre[x][axis] < centre[y][axis]; });
        bvh.nodes.push_back({});
        build(at + 1, begin, mid);
        node.right = std::uint32_t(bvh.nodes.size());
        bvh.nodes.push_back({});
        build(node.right, mid, end);
        bvh.nodes[at] = node;
    }
};

} // namespace

BoundaryBvh buildBoundaryBvh(const mesh::TetMesh& m) {
    BoundaryBvh bvh;
    const std::size_t n = m.boundaryFaces.size();
    BvhBuilder b{std::vector<Vec3>(n), std::vector<Vec3>(n), std::vector<Vec3>(n),
                 std::vector<std::uint32_t>(n), bvh};
    for (std::size_t i = 0; i < n; ++i) {
        const auto v = m.faceVertices(m.boundaryFaces[i]);
        for (int a = 0; a < 3; ++a) {
            b.lo[i][a] = std::min({m.points[v[0]][a], m.points[v[1]][a], m.points[v[2]][a]});
            b.hi[i][a] = std::max({m.points[v[0]][a], m.points[v[1]][a], m.points[v[2]][a]});
            b.centre[i][a] = 0.5 * b.lo[i][a] + 0.5 * b.hi[i][a];
        }
    }
    std::iota(b.order.begin(), b.order.end(), 0u);
    if (n == 0) return bvh;
    bvh.nodes.reserve(n);
    bvh.nodes.push_back({});
    b.build(0, 0, std::uint32_t(n));
    bvh.faces.resize(n);
    for (std::size_t i = 0; i < n; ++i)
        bvh.faces[i] = m.boundaryFaces[b.order[i]];
    return bvh;
}

std::vector<std::uint8_t> hullFaces(const mesh::TetMesh& m, const BoundaryBvh& bvh) {
    std::vector<std::uint8_t> hull(bvh.faces.size(), 0);
    if (bvh.nodes.empty()) return hull;
    const double eps = 1e-9 * 0.5 * norm(sub(m.boundsMax, m.boundsMin));
    parallelFor(bvh.faces.size(), 0u, [&](std::size_t fi) {
        const auto v = m.faceVertices(bvh.faces[fi]);
        const Vec3 a = m.points[v[0]];
        const Vec3 n = normalized(cross(sub(m.points[v[1]], a), sub(m.points[v[2]], a)));
        const double w = -dot(n, a);
        std::vector<std::uint32_t> stack{0};
        while (!stack.empty()) {
            const BvhNode& node = bvh.nodes[stack.back()];
            stack.pop_back();
            // The box's largest n.x + w: its centre's plus the half extents along |n|.
            double top = w;
            for (int k = 0; k < 3; ++k)
                top +=
                    n[k] * 0.5 * (node.lo[k] + node.hi[k]) + std::abs(n[k]) * 0.5 * (node.hi[k] - node.lo[k]);
            if (top <= eps) continue;
            if (node.count == 0) {
                stack.push_back(node.right);
                stack.push_back(std::uint32_t(&node - bvh.nodes.data()) + 1);
                continue;
            }
            for (std::uint32_t i = node.first; i < node.first + node.count; ++i)
                for (const std::uint32_t p : m.faceVertices(bvh.faces[i]))
                    if (dot(n, m.points[p]) + w > eps) return; // a point outside: not a hull face
        }
        hull[fi] = 1;
    });
    return hull;
}

namespace {

/// The nearest boundary face hit at t >= tMin among those `accept(face, dot(normal, d))` takes (barycentric
/// tolerance `tolerance`).
template <class Accept>
std::optional<EntryHit> nearestHit(const mesh::TetMesh& m, const BoundaryBvh& bvh, const Vec3& o,
                                   const Vec3& d, double tMin, double tolerance, Accept&& accept) {
    if (bvh.nodes.empty()) return std::nullopt;
    const Vec3 inv{1.0 / d[0], 1.0 / d[1], 1.0 / d[2]};
    double best = std::numeric_limits<double>::infinity();
    mesh::FaceId bestFace = mesh::kNoFace;
    std::uint32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const BvhNode& node = bvh.nodes[stack[--top]];
        // Slab test; a zero direction component gives +-inf and NaN-free comparisons via min/max order.
        double t0 = tMin, t1 = best;
        bool miss = false;
        for (int a = 0; a < 3 && !miss; ++a) {
            if (d[a] == 0.0) {
                miss = o[a] < node.lo[a] || o[a] > node.hi[a];
                continue;
            }
            double u = (node.lo[a] - o[a]) * inv[a], v = (node.hi[a] - o[a]) * inv[a];
            if (u > v) std::swap(u, v);
            // Widened by a relative margin so faces lying in a slab plane are not lost to rounding.
            const double pad = 1e-12 * (std::abs(u) + std::abs(v)) + 1e-300;
            t0 = std::max(t0, u - pad);
            t1 = std::min(t1, v + pad);
            miss = t0 > t1;
        }
        if (miss) continue;
        if (node.count == 0) {
            stack[top++] = node.right;
            stack[top++] = std::uint32_t(&node - bvh.nodes.data()) + 1;
            continue;
        }
        for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
            const mesh::FaceId f = bvh.faces[i];
            const auto v = m.faceVertices(f);
            const Vec3 a = m.points[v[0]];
            const Vec3 e1 = sub(m.points[v[1]], a), e2 = sub(m.points[v[2]], a);
            if (!accept(f, dot(cross(e1, e2), d))) continue;
            // Moller-Trumbore with barycentric tolerance.
            const Vec3 p = cross(d, e2);
            const double det = dot(e1, p);
            if (det == 0.0) continue;
            const double invDet = 1.0 / det;
            const Vec3 s = sub(o, a);
            const double u = dot(s, p) * invDet;
            if (u < -tolerance || u > 1.0 + tolerance) continue;
            const Vec3 q = cross(s, e1);
            const double w = dot(d, q) * invDet;
            if (w < -tolerance || u + w > 1.0 + tolerance) continue;
            const double t = dot(e2, q) * invDet;
            if (t >= tMin && t < best) {
                best = t;
                bestFace = f;
            }
        }
    }
    if (bestFace == mesh::kNoFace) return std::nullopt;
    return EntryHit{bestFace, best};
}

} // namespace

std::optional<EntryHit> firstEntry(const mesh::TetMesh& m, const BoundaryBvh& bvh, const Vec3& o,
                                   const Vec3& d, double tMin, const std::vector<mesh::FaceId>& exclude,
                                   double tolerance) {
    return nearestHit(m, bvh, o, d, tMin, tolerance, [&](mesh::FaceId f, double nd) {
        // Leaving or parallel faces are no entries.
        return nd < 0.0 && std::find(exclude.begin(), exclude.end(), f) == exclude.end();
    });
}

bool pointInsideMesh(const mesh::TetMesh& m, const BoundaryBvh& bvh, const Vec3& p) {
    // A direction no mesh axis or diagonal follows, so the ray rarely runs along a face or through an edge.
    const Vec3 d = normalized(Vec3{0.5345224838248488, 0.8017837257372732, 0.2672612419124244});
    const auto hit = nearestHit(m, bvh, p, d, 0.0, 1e-12, [](mesh::FaceId, double nd) { return nd != 0.0; });
    if (!hit) return false;
    return dot(facePlane(m, hit->face).normal, d) > 0.0; // the nearest boundary face is left through
}

bool mayOverlap(const mesh::TetMesh& m) {
    if (m.repairs.overlappingFaces + m.repairs.nonManifoldFaces > 0) return true;
    // Face-connected components (union-find over the tets' neighbours) and their bounding boxes.
    std::vector<std::size_t> parent(m.tets.size());
    std::iota(parent.begin(), parent.end(), std::size_t(0));
    const auto root = [&parent](std::size_t t) {
        while (parent[t] != t)
            t = parent[t] = parent[parent[t]];
        return t;
    };
    for (std::size_t t = 0; t < m.tets.size(); ++t)
        for (unsigned f = 0; f < 4; ++f) {
            const mesh::FaceId nb = m.neighbors[mesh::faceId(t, f)];
            if (nb != mesh::kNoFace) parent[root(t)] = root(mesh::faceTet(nb));
        }
    struct Box {
        Vec3 lo, hi;
    };
    const double inf = std::numeric_limits<double>::infinity();
    std::vector<std::size_t> slot(m.tets.size(), std::size_t(-1));
    std::vector<Box> boxes;
    for (std::size_t t = 0; t < m.tets.size(); ++t) {
        std::size_t& k = slot[root(t)];
        if (k == std::size_t(-1)) {
            k = boxes.size();
            boxes.push_back({{inf, inf, inf}, {-inf, -inf, -inf}});
        }
        for (const auto v : m.tets[t])
            for (int a = 0; a < 3; ++a) {
                boxes[k].lo[a] = std::min(boxes[k].lo[a], double(m.points[v][a]));
                boxes[k].hi[a] = std::max(boxes[k].hi[a], double(m.points[v][a]));
            }
    }
    // Boxes that only touch (components meeting in a plane) do not count: the overlap must exceed rounding.
    const double slack = 1e-9 * norm(sub(m.boundsMax, m.boundsMin));
    std::sort(boxes.begin(), boxes.end(), [](const Box& a, const Box& b) { return a.lo[0] < b.lo[0]; });
    for (std::size_t i = 0; i < boxes.size(); ++i)
        for (std::size_t j = i + 1; j < boxes.size() && boxes[j].lo[0] < boxes[i].hi[0] - slack; ++j) {
            bool overlap = true;
            for (int a = 1; a < 3; ++a)
                overlap = overlap && boxes[j].lo[a] < boxes[i].hi[a] - slack &&
                          boxes[i].lo[a] < boxes[j].hi[a] - slack;
            if (overlap) return true;
        }
    return false;
}

namespace {

/// Whether the interiors of two tets overlap by more than `tol` (times the axis length) on every separating
/// axis candidate: the 8 face normals and the 36 cross products of an edge of each. Convex solids whose interiors
/// are disjoint have a separating plane among these, touching ones (shared faces, edges, vertices) included.
bool tetsOverlap(const std::array<Vec3, 4>& a, const std::array<Vec3, 4>& b, double tol) {
    const auto separates = [&](const Vec3& n) {
        const double len2 = dot(n, n);
        if (!(len2 > 0.0)) return false;
        double a0 = dot(n, a[0]), a1 = a0, b0 = dot(n, b[0]), b1 = b0;
        for (int i = 1; i < 4; ++i) {
            a0 = std::min(a0, dot(n, a[i]));
            a1 = std::max(a1, dot(n, a[i]));
            b0 = std::min(b0, dot(n, b[i]));
            b1 = std::max(b1, dot(n, b[i]));
        }
        // Overlap of the projections at most tol in length units (n is not normalised).
        const double gap = std::min(a1 - b0, b1 - a0);
        return gap <= 0.0 || gap * gap <= tol * tol * len2;
    };
    static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
    for (const auto* t : {&a, &b})
        for (int f = 0; f < 4; ++f) {
            const Vec3& p = (*t)[(f + 1) % 4];
            if (separates(cross(sub((*t)[(f + 2) % 4], p), sub((*t)[(f + 3) % 4], p)))) return false;
        }
    for (const auto& ea : kEdges)
        for (const auto& eb : kEdges)
            if (separates(cross(sub(a[ea[1]], a[ea[0]]), sub(b[eb[1]], b[eb[0]])))) return false;
    return true;
}

} // namespace

std::vector<std::uint8_t> overlappingTets(const mesh::TetMesh& m) {
    const std::size_t n = m.tets.size();
    std::vector<std::array<Vec3, 4>> corners(n);
    std::vector<Vec3> lo(n), hi(n);
    for (std::size_t t = 0; t < n; ++t) {
        for (int i = 0; i < 4; ++i)
            corners[t][i] = m.points[m.tets[t][i]];
        for (int a = 0; a < 3; ++a) {
            lo[t][a] = std::min({corners[t][0][a], corners[t][1][a], corners[t][2][a], corners[t][3][a]});
            hi[t][a] = std::max({corners[t][0][a], corners[t][1][a], corners[t][2][a], corners[t][3][a]});
        }
    }
    const double tol = 1e-9 * norm(sub(m.boundsMax, m.boundsMin));
    // Candidate pairs from a box tree over the tets (median split on the longest axis of the box centres, at
    // most 4 tets a leaf; it adapts to graded meshes where a uniform grid would crowd thin cells): each tet asks
    // it for the tets after it whose boxes overlap its own.
    struct Node {
        Vec3 lo, hi;
        std::size_t first, count, right; ///< leaf: order[first, first + count); inner: count 0, right child
    };
    std::vector<Node> nodes;
    std::vector<std::size_t> order(n);
    std::iota(order.begin(), order.end(), std::size_t(0));
    const auto build = [&](auto&& self, std::size_t first, std::size_t count) -> std::size_t {
        const std::size_t index = nodes.size();
        nodes.push_back({lo[order[first]], hi[order[first]], first, count, 0});
        Vec3 clo = nodes[index].lo, chi = nodes[index].hi;
        for (std::size_t i = first; i < first + count; ++i)
            for (int a = 0; a < 3; ++a) {
                nodes[index].lo[a] = std::min(nodes[index].lo[a], lo[order[i]][a]);
                nodes[index].hi[a] = std::max(nodes[index].hi[a], hi[order[i]][a]);
                const double c = lo[order[i]][a] + hi[order[i]][a];
                clo[a] = std::min(clo[a], c);
                chi[a] = std::max(chi[a], c);
            }
        if (count <= 4) return index;
        int axis = 0;
        for (int a = 1; a < 3; ++a)
            if (chi[a] - clo[a] > chi[axis] - clo[axis]) axis = a;
        const std::size_t half = count / 2;
        std::nth_element(order.begin() + std::ptrdiff_t(first), order.begin() + std::ptrdiff_t(first + half),
                         order.begin() + std::ptrdiff_t(first + count), [&](std::size_t x, std::size_t y) {
                             return lo[x][axis] + hi[x][axis] < lo[y][axis] + hi[y][axis];
                         });
        nodes[index].count = 0;
        self(self, first, half);
        const std::size_t right = self(self, first + half, count - half);
        nodes[index].right = right;
        return index;
    };
    if (n > 0) build(build, 0, n);
    const auto boxesOverlap = [tol](const Vec3& alo, const Vec3& ahi, const Vec3& blo, const Vec3& bhi) {
        for (int a = 0; a < 3; ++a)
            if (!(blo[a] < ahi[a] - tol && alo[a] < bhi[a] - tol)) return false;
        return true;
    };
    std::vector<std::vector<std::size_t>> found(n); // per tet: the tets after it that overlap it
    // Work budget: tree nodes visited plus tet pairs tested. Tets that span much of the mesh (a grid whose
    // points were shuffled) make every box overlap every other, n^2 / 2 pairs (224,864 tets: 56 s); past the
    // budget every tet is reported as overlapping, which only costs the caster checks it may not need.
    const std::size_t budget = std::max<std::size_t>(kOverlapWorkPerTet * n, std::size_t(1) << 20);
    std::atomic<std::size_t> work{0};
    std::atomic<bool> overBudget{false};
    parallelFor(n, 0u, [&](std::size_t t) {
        if (overBudget.load(std::memory_order_relaxed)) return;
        std::size_t mine = 0;
        std::vector<std::size_t> stack{0};
        while (!stack.empty()) {
            if (++mine >= 4096) {
                if (work.fetch_add(mine, std::memory_order_relaxed) + mine > budget) {
                    overBudget.store(true, std::memory_order_relaxed);
                    return;
                }
                mine = 0;
            }
            const Node& node = nodes[stack.back()];
            const std::size_t ni = stack.back();
            stack.pop_back();
            if (!boxesOverlap(node.lo, node.hi, lo[t], hi[t])) continue;
            if (node.count == 0) {
                stack.push_back(ni + 1);
                stack.push_back(node.right);
                continue;
            }
            mine += node.count;
            for (std::size_t i = node.first; i < node.first + node.count; ++i) {
                const std::size_t u = order[i];
                if (u <= t || !boxesOverlap(lo[u], hi[u], lo[t], hi[t])) continue;
                // Face neighbours lie on opposite sides of their shared face.
                bool neighbours = false;
                for (unsigned f = 0; f < 4; ++f) {
                    const mesh::FaceId nb = m.neighbors[mesh::faceId(t, f)];
                    neighbours = neighbours || (nb != mesh::kNoFace && mesh::faceTet(nb) == u);
                }
                if (neighbours) continue;
                mine += kOverlapTestWork;
                if (tetsOverlap(corners[t], corners[u], tol)) found[t].push_back(u);
            }
        }
        work.fetch_add(mine, std::memory_order_relaxed);
    });
    if (overBudget.load() || work.load() > budget) return std::vector<std::uint8_t>(n, 1);
    std::vector<std::uint8_t> overlaps(n, 0);
    for (std::size_t t = 0; t < n; ++t)
        for (const std::size_t u : found[t]) {
            overlaps[t] = 1;
            overlaps[u] = 1;
        }
    return overlaps;
}

} // namespace volcl::mesh_detail
