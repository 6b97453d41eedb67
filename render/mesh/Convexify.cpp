// Convexification: the Delaunay tets of the mesh's points that lie outside it become auxiliary cells, linked to
// each other and to the mesh's boundary faces (exactly, or through overlapping near-coplanar faces).
#include "render/mesh/Convexify.hpp"

#include "core/Error.hpp"
#include "core/runtime/Timing.hpp"
#include "render/mesh/MeshGeometry.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <unordered_map>

extern "C" {
#include <libqhull_r/qhull_ra.h>
}

namespace volcl {
namespace {

using Triple = std::array<std::uint32_t, 3>;

struct TripleHash {
    std::size_t operator()(const Triple& t) const noexcept {
        std::uint64_t h = t[0];
        h = h * 0x9E3779B97F4A7C15ULL ^ t[1];
        h = h * 0x9E3779B97F4A7C15ULL ^ t[2];
        return static_cast<std::size_t>(h ^ (h >> 29));
    }
};

Triple sorted(Triple t) {
    std::sort(t.begin(), t.end());
    return t;
}

/// The Delaunay tetrahedralisation of the points (lower facets of the lifted hull), four point indices each.
std::vector<mesh::Tet> delaunayTets(const std::vector<mesh::Point3>& points) {
    std::vector<coordT> coords(3 * points.size());
    for (std::size_t i = 0; i < points.size(); ++i)
        for (int a = 0; a < 3; ++a)
            coords[3 * i + std::size_t(a)] = points[i][std::size_t(a)];
    char* text = nullptr;
    std::size_t textSize = 0;
    FILE* err = open_memstream(&text, &textSize); // Qhull's messages, for the error below
    qhT qhData;
    qhT* qh = &qhData;
    qh_zero(qh, err);
    char flags[] = "qhull d Qbb Qz Qt";
    const int code =
        qh_new_qhull(qh, 3, static_cast<int>(points.size()), coords.data(), False, flags, nullptr, err);
    std::vector<mesh::Tet> tets;
    if (code == 0) {
        facetT* facet;
        vertexT *vertex, **vertexp;
        FORALLfacets {
            if (facet->upperdelaunay) continue;
            mesh::Tet t{};
            int k = 0;
            bool ok = true;
            FOREACHvertex_(facet->vertices) {
                const int id = qh_pointid(qh, vertex->point);
                if (k >= 4 || id < 0 || std::size_t(id) >= points.size())
                    ok = false;
                else
                    t[std::size_t(k++)] = static_cast<std::uint32_t>(id);
            }
            if (ok && k == 4) tets.push_back(t);
        }
    }
    qh_freeqhull(qh, !qh_ALL);
    int curLong = 0, totLong = 0;
    qh_memfreeshort(qh, &curLong, &totLong);
    std::fclose(err);
    std::string message(text ? text : "", textSize);
    std::free(text);
    if (code != 0) {
        const auto line = message.find('\n');
        throw DataError("convexification: the Delaunay tetrahedralisation failed (Qhull: " +
                        message.substr(0, line) + ")");
    }
    return tets;
}

/// 6 V of the tet (positive for positive orientation) and its longest edge.
double sixVolume(const mesh::TetMesh& m, const mesh::Tet& t, double& longest) {
    const Vec3 p0 = m.points[t[0]];
    const Vec3 e1 = sub(m.points[t[1]], p0), e2 = sub(m.points[t[2]], p0), e3 = sub(m.points[t[3]], p0);
    longest = 0;
    for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j)
            longest = std::max(longest, norm(sub(m.points[t[std::size_t(i)]], m.points[t[std::size_t(j)]])));
    return dot(e1, cross(e2, e3));
}

/// A cell face: its points in outward winding and its cell.
struct CellFace {
    Triple v;
    std::uint32_t cell = 0;
};

Vec3 faceNormal(const mesh::TetMesh& m, const Triple& v) {
    const Vec3 a = m.points[v[0]];
    return cross(sub(m.points[v[1]], a), sub(m.points[v[2]], a));
}

/// Whether triangles a and b, projected along unit normal n, overlap with positive area (separating axes: the
/// edge normals of both; an overlap thinner than `eps` does not count).
bool overlapInPlane(const mesh::TetMesh& m, const Triple& a, const Triple& b, const Vec3& n, double eps) {
    const Vec3 u = normalized(std::abs(n[0]) < 0.9 ? cross(n, Vec3{1, 0, 0}) : cross(n, Vec3{0, 1, 0}));
    const Vec3 w = cross(n, u);
    std::array<std::array<double, 2>, 3> pa, pb;
    for (int i = 0; i < 3; ++i) {
        const Vec3& p = m.points[a[std::size_t(i)]];
        const Vec3& q = m.points[b[std::size_t(i)]];
        pa[std::size_t(i)] = {dot(p, u), dot(p, w)};
        pb[std::size_t(i)] = {dot(q, u), dot(q, w)};
    }
    for (const auto* tri : {&pa, &pb})
        for (int i = 0; i < 3; ++i) {
            const auto& p = (*tri)[std::size_t(i)];
            const auto& q = (*tri)[std::size_t((i + 1) % 3)];
            const double ax = q[1] - p[1], ay = p[0] - q[0];
            const double len = std::hypot(ax, ay);
            if (len == 0.0) return false;
            double loA = 1e300, hiA = -1e300, loB = 1e300, hiB = -1e300;
            for (int k = 0; k < 3; ++k) {
                const double sa = (pa[std::size_t(k)][0] * ax + pa[std::size_t(k)][1] * ay) / len;
                const double sb = (pb[std::size_t(k)][0] * ax + pb[std::size_t(k)][1] * ay) / len;
                loA = std::min(loA, sa);
                hiA = std::max(hiA, sa);
                loB = std::min(loB, sb);
                hiB = std::max(hiB, sb);
            }
            if (std::min(hiA, hiB) - std::max(loA, loB) <= eps) return false;
        }
    return true;
}

} // namespace

Convexification convexify(const mesh::TetMesh& mesh) {
    Stopwatch sw;
    Convexification out;
    VisibilityGraph& g = out.graph;
    std::vector<GraphLink> links;
    addMeshCells(g, mesh, links);

    const mesh_detail::BoundaryBvh bvh = mesh_detail::buildBoundaryBvh(mesh);
    const std::vector<std::uint8_t> hullFlags = mesh_detail::hullFaces(mesh, bvh);
    std::vector<std::uint8_t> onHull(4 * mesh.tetCount(), 0);
    for (std::size_t i = 0; i < bvh.faces.size(); ++i)
        onHull[bvh.faces[i]] = hullFlags[i];
    const bool convex =
        std::all_of(hullFlags.begin(), hullFlags.end(), [](std::uint8_t h) { return h != 0; });

    // A convex mesh needs nothing; Qhull needs 5 points in general position for a 3D Delaunay.
    if (!convex && mesh.pointCount() >= 5) {
        std::vector<std::uint8_t> boundaryPoint(mesh.pointCount(), 0);
        for (const mesh::FaceId f : mesh.boundaryFaces)
            for (const std::uint32_t p : mesh.faceVertices(f))
                boundaryPoint[p] = 1;
        struct TetKey {
            std::array<std::uint32_t, 4> v;
            bool operator==(const TetKey& o) const noexcept { return v == o.v; }
        };
        struct TetKeyHash {
            std::size_t operator()(const TetKey& k) const noexcept {
                return TripleHash{}(Triple{k.v[0], k.v[1], k.v[2] ^ (k.v[3] * 0x85EBCA6Bu)});
            }
        };
        std::unordered_map<TetKey, std::uint32_t, TetKeyHash> meshTets;
        meshTets.reserve(mesh.tetCount());
        for (std::size_t t = 0; t < mesh.tetCount(); ++t) {
            TetKey k{mesh.tets[t]};
            std::sort(k.v.begin(), k.v.end());
            meshTets.emplace(k, static_cast<std::uint32_t>(t));
        }

        std::vector<mesh::Tet> delaunay;
        try {
            delaunay = delaunayTets(mesh.points);
        } catch (
            const DataError& e) { // e.g. points too close to one plane: no auxiliary cells, said in stats
            out.stats.delaunayError = e.what();
        }
        out.stats.delaunayTets = delaunay.size();
        std::vector<mesh::Tet> aux;
        for (mesh::Tet t : delaunay) {
            double longest = 0;
            const double v6 = sixVolume(mesh, t, longest);
            if (!(std::abs(v6) > 1e-12 * longest * longest * longest)) continue; // flat
            if (v6 < 0) std::swap(t[1], t[2]);
            TetKey k{t};
            std::sort(k.v.begin(), k.v.end());
            if (meshTets.count(k)) continue; // a tet of the mesh
            if (!boundaryPoint[t[0]] && !boundaryPoint[t[1]] && !boundaryPoint[t[2]] && !boundaryPoint[t[3]])
                continue; // four points inside the mesh
            Vec3 c{0, 0, 0};
            for (const std::uint32_t p : t)
                c = add(c, mesh.points[p]);
            if (mesh_detail::pointInsideMesh(mesh, bvh, scale(c, 0.25))) continue;
            aux.push_back(t);
        }
        out.stats.auxiliaryCells = aux.size();
        const std::uint32_t firstAux = static_cast<std::uint32_t>(mesh.tetCount());
        if (mesh.tetCount() + aux.size() >= std::size_t{0x7FFFFFFFu})
            throw DataError("convexification: too many cells");
        for (const mesh::Tet& t : aux) {
            Vec3 c{0, 0, 0};
            for (const std::uint32_t p : t)
                c = add(c, mesh.points[p]);
            g.centroids.push_back(scale(c, 0.25));
        }

        // Exact links: a triangle of an auxiliary cell that another auxiliary cell or a boundary face also has.
        std::unordered_map<Triple, std::uint32_t, TripleHash> byTriple; // -> index into faces
        std::vector<CellFace> faces;
        std::vector<std::uint8_t> matched;
        faces.reserve(4 * aux.size() + mesh.boundaryFaces.size());
        byTriple.reserve(4 * aux.size() + mesh.boundaryFaces.size());
        for (const mesh::FaceId f : mesh.boundaryFaces) {
            const auto v = mesh.faceVertices(f);
            byTriple.emplace(sorted(v), static_cast<std::uint32_t>(faces.size()));
            faces.push_back({v, static_cast<std::uint32_t>(mesh::faceTet(f))});
        }
        const std::size_t meshFaceCount = faces.size();
        matched.assign(meshFaceCount, 0);
        for (std::size_t i = 0; i < meshFaceCount; ++i)
            if (onHull[mesh.boundaryFaces[i]]) matched[i] = 1; // nothing lies beyond it
        for (std::size_t a = 0; a < aux.size(); ++a)
            for (unsigned k = 0; k < 4; ++k) {
                const auto& lv = mesh::kTetFaceVertices[k];
                const Triple v{aux[a][lv[0]], aux[a][lv[1]], aux[a][lv[2]]};
                const std::uint32_t cell = firstAux + static_cast<std::uint32_t>(a);
                const auto [it, fresh] =
                    byTriple.emplace(sorted(v), static_cast<std::uint32_t>(faces.size()));
                faces.push_back({v, cell});
                matched.push_back(0);
                if (fresh) continue;
                const std::uint32_t j = it->second;
                if (matched[j]) continue;
                // Through this face's plane, its outward normal pointing from this cell into the other one.
                links.push_back({cell, faces[j].cell, addPlane(g, faceNormal(mesh, v), mesh.points[v[0]])});
                matched[j] = matched.back() = 1;
                ++out.stats.exactLinks;
            }

        // Geometric links between the faces left over that share a point.
        std::vector<std::uint32_t> open;
        for (std::size_t i = 0; i < faces.size(); ++i)
            if (!matched[i]) open.push_back(static_cast<std::uint32_t>(i));
        std::vector<std::uint32_t> start(mesh.pointCount() + 1, 0), incident;
        for (const std::uint32_t i : open)
            for (const std::uint32_t p : faces[i].v)
                ++start[p + 1];
        for (std::size_t p = 0; p < mesh.pointCount(); ++p)
            start[p + 1] += start[p];
        incident.resize(start.back());
        {
            std::vector<std::uint32_t> at(start.begin(), start.end() - 1);
            for (const std::uint32_t i : open)
                for (const std::uint32_t p : faces[i].v)
                    incident[at[p]++] = i;
        }
        const double eps = 1e-9 * norm(sub(mesh.boundsMax, mesh.boundsMin));
        std::vector<std::uint8_t> linked(faces.size(), 0);
        std::vector<std::uint32_t> candidates;
        for (const std::uint32_t i : open) {
            if (i < meshFaceCount) continue; // from the auxiliary side only
            const Vec3 ni = normalized(faceNormal(mesh, faces[i].v));
            candidates.clear();
            for (const std::uint32_t p : faces[i].v)
                for (std::uint32_t e = start[p]; e < start[p + 1]; ++e)
                    candidates.push_back(incident[e]);
            std::sort(candidates.begin(), candidates.end());
            candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
            for (const std::uint32_t j : candidates) {
                if (faces[j].cell == faces[i].cell) continue;
                if (j >= meshFaceCount && j < i) continue; // an auxiliary pair is tried once
                const Vec3 nj = normalized(faceNormal(mesh, faces[j].v));
                if (!(dot(ni, nj) < -0.9)) continue;
                if (!overlapInPlane(mesh, faces[i].v, faces[j].v, ni, eps)) continue;
                links.push_back({faces[i].cell, faces[j].cell,
                                 addPlane(g, faceNormal(mesh, faces[i].v), mesh.points[faces[i].v[0]])});
                linked[i] = linked[j] = 1;
                ++out.stats.geometricLinks;
            }
        }
        // Contacts: two boundary faces of the mesh in one plane, facing each other and overlapping, without a
        // common triangle (parts that touch along a plane with different triangulations, a T-junction).
        std::vector<std::uint32_t> faceIndex(4 * mesh.tetCount(), 0);
        for (std::size_t i = 0; i < meshFaceCount; ++i)
            faceIndex[mesh.boundaryFaces[i]] = static_cast<std::uint32_t>(i);
        const double planeTolerance = 1e-7 * norm(sub(mesh.boundsMax, mesh.boundsMin));
        std::vector<std::uint32_t> stack;
        for (std::size_t i = 0; i < meshFaceCount; ++i) {
            if (matched[i]) continue;
            const Triple& vi = faces[i].v;
            const Vec3 ni = normalized(faceNormal(mesh, vi));
            Vec3 lo = mesh.points[vi[0]], hi = lo;
            for (const std::uint32_t p : vi)
                for (int a = 0; a < 3; ++a) {
                    lo[std::size_t(a)] =
                        std::min(lo[std::size_t(a)], mesh.points[p][std::size_t(a)] - planeTolerance);
                    hi[std::size_t(a)] =
                        std::max(hi[std::size_t(a)], mesh.points[p][std::size_t(a)] + planeTolerance);
                }
            stack.assign(1, 0);
            while (!stack.empty()) {
                const mesh_detail::BvhNode& node = bvh.nodes[stack.back()];
                stack.pop_back();
                bool apart = false;
                for (int a = 0; a < 3; ++a)
                    apart = apart || node.hi[std::size_t(a)] < lo[std::size_t(a)] ||
                            node.lo[std::size_t(a)] > hi[std::size_t(a)];
                if (apart) continue;
                if (node.count == 0) {
                    stack.push_back(node.right);
                    stack.push_back(static_cast<std::uint32_t>(&node - bvh.nodes.data()) + 1);
                    continue;
                }
                for (std::uint32_t k = node.first; k < node.first + node.count; ++k) {
                    const std::uint32_t j = faceIndex[bvh.faces[k]];
                    if (j <= i || matched[j] || faces[j].cell == faces[i].cell) continue;
                    const Triple& vj = faces[j].v;
                    if (!(dot(ni, normalized(faceNormal(mesh, vj))) < -0.999)) continue;
                    bool coplanar = true;
                    for (const std::uint32_t p : vj)
                        coplanar = coplanar && std::abs(dot(ni, sub(mesh.points[p], mesh.points[vi[0]]))) <=
                                                   planeTolerance;
                    if (!coplanar || !overlapInPlane(mesh, vi, vj, ni, eps)) continue;
                    links.push_back({faces[i].cell, faces[j].cell,
                                     addPlane(g, faceNormal(mesh, vi), mesh.points[vi[0]])});
                    linked[i] = linked[j] = 1;
                    ++out.stats.contactLinks;
                }
            }
        }
        for (std::size_t i = 0; i < meshFaceCount; ++i)
            if (!matched[i] && !linked[i]) ++out.stats.openBoundaryFaces;
    }
    buildAdjacency(g, links);
    out.stats.seconds = sw.milliseconds() * 1e-3;
    return out;
}

} // namespace volcl
