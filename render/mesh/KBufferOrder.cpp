// Face order of the k-buffer placed by a visibility order of the cells.
#include "render/mesh/KBufferOrder.hpp"

#include "core/Error.hpp"
#include "core/runtime/Timing.hpp"
#include "render/VecMath.hpp"
#include "render/mesh/MeshGeometry.hpp"

#include <string>

namespace volcl {

MeshSort defaultKBufferSort(const mesh::TetMesh& mesh) {
    return mesh_detail::mayOverlap(mesh) ? MeshSort::Centroid : defaultMeshSort(mesh);
}

KBufferFaceSorter::KBufferFaceSorter(const mesh::TetMesh& mesh, const MeshFaces& faces,
                                     VisibilitySorter& cells)
    : mesh_(mesh), cells_(cells), begin_(4 * mesh.tetCount(), 0), end_(4 * mesh.tetCount(), 0) {
    if (faces.faces.size() > 0xFFFFFFFFu)
        throw DataError("mesh has too many faces for the k-buffer (2^32 - 1)");
    for (std::size_t j = 0; j < faces.faces.size(); ++j) {
        const mesh::FaceId s = faces.faces[j].source;
        if (s == mesh::kNoFace || s >= begin_.size())
            throw Error("internal: k-buffer face " + std::to_string(j) + " names no tet face");
        const auto at = static_cast<std::uint32_t>(j);
        if (end_[s] == 0)
            begin_[s] = at;
        else if (end_[s] != at)
            throw Error("internal: the pieces of k-buffer face " + std::to_string(j) + " are not adjacent");
        end_[s] = at + 1;
        const mesh::FaceId other = mesh_.neighbors[s];
        if (other != mesh::kNoFace) {
            begin_[other] = begin_[s];
            end_[other] = end_[s];
        }
    }
}

std::vector<std::uint32_t> KBufferFaceSorter::placeFaces(const std::vector<std::uint32_t>& cellsBackToFront,
                                                         const SortView& view, std::size_t drawn) const {
    std::vector<std::uint32_t> out;
    out.reserve(drawn);
    std::vector<std::uint8_t> seen(mesh_.tetCount(), 0);
    for (auto it = cellsBackToFront.rbegin(); it != cellsBackToFront.rend(); ++it) {
        const std::uint32_t t = *it;
        seen[t] = 1;
        // The faces the eye sees from outside the tet (outward winding, positively oriented tets): the ray
        // enters through them, so their fragments come before the exit face's.
        bool front[4];
        for (unsigned l = 0; l < 4; ++l) {
            const auto v = mesh_.faceVertices(mesh::faceId(t, l));
            const Vec3& a = mesh_.points[v[0]];
            const Vec3 n = cross(sub(mesh_.points[v[1]], a), sub(mesh_.points[v[2]], a));
            front[l] = view.perspective ? dot(n, sub(view.eye, a)) > 0.0 : dot(n, view.direction) < 0.0;
        }
        for (const bool entering : {true, false})
            for (unsigned l = 0; l < 4; ++l) {
                if (front[l] != entering) continue;
                const mesh::FaceId f = mesh::faceId(t, l);
                const mesh::FaceId other = mesh_.neighbors[f];
                if (other != mesh::kNoFace && seen[mesh::faceTet(other)])
                    continue; // placed with the nearer tet
                for (std::uint32_t j = begin_[f]; j < end_[f] && j < drawn; ++j)
                    out.push_back(j);
            }
    }
    return out;
}

KBufferFaceOrder KBufferFaceSorter::order(const SortView& view, MeshSort method, std::size_t drawn) {
    KBufferFaceOrder out;
    const VisibilityOrder cells = cells_.sort(view, method);
    out.cyclesBroken = cells.cyclesBroken;
    out.cellSortMs = cells.seconds * 1000.0;
    Stopwatch sw;
    out.faces = placeFaces(cells.tets, view, drawn);
    out.faceOrderMs = sw.milliseconds();
    return out;
}

} // namespace volcl
