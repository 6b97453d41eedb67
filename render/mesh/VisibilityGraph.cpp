// MPVO's cell graph: CSR adjacency through planes, the mesh's face-adjacency graph, and Kahn's sort with cycle
// breaking.
#include "render/mesh/VisibilityGraph.hpp"

#include "core/Error.hpp"
#include "render/mesh/VisibilitySort.hpp"

#include <algorithm>
#include <limits>

namespace volcl {

void buildAdjacency(VisibilityGraph& g, const std::vector<GraphLink>& links) {
    const std::size_t cells = g.cellCount();
    if (2 * links.size() >= std::size_t{0xFFFFFFFFu}) throw DataError("visibility graph: too many links");
    g.first.assign(cells + 1, 0);
    for (const GraphLink& l : links) {
        ++g.first[l.negative + 1];
        ++g.first[l.positive + 1];
    }
    for (std::size_t c = 0; c < cells; ++c)
        g.first[c + 1] += g.first[c];
    g.other.assign(2 * links.size(), 0);
    g.plane.assign(2 * links.size(), 0);
    std::vector<std::uint32_t> at(g.first.begin(), g.first.end() - 1);
    for (const GraphLink& l : links) {
        const std::uint32_t a = at[l.negative]++, b = at[l.positive]++;
        g.other[a] = l.positive;
        g.plane[a] = l.plane * 2;
        g.other[b] = l.negative;
        g.plane[b] = l.plane * 2 + 1;
    }
}

std::uint32_t addPlane(VisibilityGraph& g, const Vec3& normal, const Vec3& point) {
    g.normals.push_back(normal);
    g.offsets.push_back(dot(normal, point));
    return static_cast<std::uint32_t>(g.normals.size() - 1);
}

void addMeshCells(VisibilityGraph& g, const mesh::TetMesh& mesh, std::vector<GraphLink>& links) {
    if (!g.centroids.empty()) throw Error("internal: the mesh's tets must be the graph's first cells");
    g.realCells = mesh.tetCount();
    g.centroids.resize(mesh.tetCount());
    for (std::size_t t = 0; t < mesh.tetCount(); ++t) {
        Vec3 c{0, 0, 0};
        for (const std::uint32_t v : mesh.tets[t])
            c = add(c, mesh.points[v]);
        g.centroids[t] = scale(c, 0.25);
    }
    links.reserve(links.size() + mesh.internalFaceCount());
    g.normals.reserve(g.normals.size() + mesh.internalFaceCount());
    g.offsets.reserve(g.offsets.size() + mesh.internalFaceCount());
    for (std::size_t f = 0; f < mesh.neighbors.size(); ++f) {
        const mesh::FaceId n = mesh.neighbors[f];
        if (n == mesh::kNoFace || n < f) continue; // boundary, or the copy seen from the other tet
        const auto v = mesh.faceVertices(static_cast<mesh::FaceId>(f));
        const Vec3 a = mesh.points[v[0]];
        const Vec3 normal = cross(sub(mesh.points[v[1]], a), sub(mesh.points[v[2]], a)); // out of tet f / 4
        links.push_back({static_cast<std::uint32_t>(mesh::faceTet(static_cast<mesh::FaceId>(f))),
                         static_cast<std::uint32_t>(mesh::faceTet(n)), addPlane(g, normal, a)});
    }
}

VisibilityGraph meshAdjacencyGraph(const mesh::TetMesh& mesh) {
    VisibilityGraph g;
    std::vector<GraphLink> links;
    addMeshCells(g, mesh, links);
    buildAdjacency(g, links);
    return g;
}

namespace {

/// Distance of a cell from the viewer along the view (larger: farther).
double viewDistance(const SortView& view, const Vec3& p) {
    if (!view.perspective) return dot(p, view.direction);
    const Vec3 d = sub(p, view.eye);
    return dot(d, d);
}

} // namespace

GraphOrder sortGraph(const VisibilityGraph& g, const SortView& view) {
    const std::size_t cells = g.cellCount(), planes = g.normals.size();
    // Per plane: +1 when the view's rays cross it from the negative to the positive side, -1 the other way,
    // 0 when they run along it (no order is needed between the two cells then).
    std::vector<std::int8_t> side(planes);
    for (std::size_t p = 0; p < planes; ++p) {
        const double s =
            view.perspective ? g.offsets[p] - dot(g.normals[p], view.eye) : dot(g.normals[p], view.direction);
        side[p] = static_cast<std::int8_t>((s > 0) - (s < 0));
    }
    // relation(e) > 0: the entry's cell is in front of the other one (the other must go out first).
    auto relation = [&](std::uint32_t e) {
        const int s = side[g.plane[e] >> 1];
        return (g.plane[e] & 1u) ? -s : s;
    };
    std::vector<std::uint32_t> behind(cells, 0); // cells behind each cell not yet out
    for (std::size_t c = 0; c < cells; ++c)
        for (std::uint32_t e = g.first[c]; e < g.first[c + 1]; ++e)
            if (relation(e) > 0) ++behind[c];

    GraphOrder out;
    out.tets.reserve(g.realCells);
    std::vector<std::uint8_t> done(cells, 0);
    std::vector<std::uint32_t> queue;
    queue.reserve(cells);
    std::size_t head = 0;
    for (std::size_t c = 0; c < cells; ++c)
        if (behind[c] == 0) queue.push_back(static_cast<std::uint32_t>(c));
    auto release = [&](std::uint32_t c) {
        done[c] = 1;
        if (c < g.realCells) out.tets.push_back(c);
        for (std::uint32_t e = g.first[c]; e < g.first[c + 1]; ++e) {
            const std::uint32_t o = g.other[e];
            if (!done[o] && relation(e) < 0 && --behind[o] == 0) queue.push_back(o);
        }
    };

    std::vector<std::uint32_t> stamp(cells, 0), path;
    std::size_t scan = 0, released = 0;
    while (released < cells) {
        if (head < queue.size()) {
            release(queue[head++]);
            ++released;
            continue;
        }
        // A cycle: every remaining cell has a remaining cell behind it. Walk behind until a cell repeats.
        while (done[scan])
            ++scan;
        const std::uint32_t round = static_cast<std::uint32_t>(++out.cyclesBroken);
        path.clear();
        std::uint32_t cur = static_cast<std::uint32_t>(scan);
        while (stamp[cur] != round) {
            stamp[cur] = round;
            path.push_back(cur);
            std::uint32_t next = cur;
            for (std::uint32_t e = g.first[cur]; e < g.first[cur + 1]; ++e)
                if (!done[g.other[e]] && relation(e) > 0) {
                    next = g.other[e];
                    break;
                }
            if (next == cur)
                throw Error("internal: visibility sort found a blocked cell with nothing behind it");
            cur = next;
        }
        const auto start = std::find(path.begin(), path.end(), cur);
        std::uint32_t victim = cur;
        double farthest = -std::numeric_limits<double>::infinity();
        bool aux = false;
        for (auto it = start; it != path.end(); ++it) {
            if (*it >= g.realCells) { // Guthe: delete an auxiliary cell of the cycle
                victim = *it;
                aux = true;
                break;
            }
            const double d = viewDistance(view, g.centroids[*it]);
            if (d > farthest) {
                farthest = d;
                victim = *it;
            }
        }
        if (aux) ++out.auxDeleted;
        release(victim);
        ++released;
    }
    return out;
}

} // namespace volcl
