// Visibility orders of a tet mesh: centroid radix sort, MPVO on the face-adjacency graph, MPVO over the
// convexified mesh; the graphs and the convexification are built on first use and kept.
#include "render/mesh/VisibilitySort.hpp"

#include "core/Error.hpp"
#include "core/runtime/Timing.hpp"
#include "render/mesh/Convexify.hpp"
#include "render/mesh/MeshGeometry.hpp"
#include "render/mesh/RadixSort.hpp"
#include "render/mesh/VisibilityGraph.hpp"

#include <algorithm>
#include <optional>
#include <string>

namespace volcl {

std::string_view meshSortName(MeshSort s) {
    switch (s) {
    case MeshSort::Centroid:
        return "centroid";
    case MeshSort::Mpvo:
        return "mpvo";
    case MeshSort::Convexified:
        return "convexified";
    }
    return "convexified";
}

MeshSort parseMeshSort(std::string_view s) {
    if (s == "centroid") return MeshSort::Centroid;
    if (s == "mpvo") return MeshSort::Mpvo;
    if (s == "convexified") return MeshSort::Convexified;
    throw UsageError("render.sort '" + std::string(s) +
                     "' is unknown (expected centroid, mpvo, convexified)");
}

bool meshIsConvex(const mesh::TetMesh& mesh) {
    const mesh_detail::BoundaryBvh bvh = mesh_detail::buildBoundaryBvh(mesh);
    const std::vector<std::uint8_t> hull = mesh_detail::hullFaces(mesh, bvh);
    return std::all_of(hull.begin(), hull.end(), [](std::uint8_t h) { return h != 0; });
}

MeshSort defaultMeshSort(const mesh::TetMesh& mesh) {
    return meshIsConvex(mesh) ? MeshSort::Mpvo : MeshSort::Convexified;
}

struct VisibilitySorter::Impl {
    const mesh::TetMesh& mesh;
    std::vector<Vec3> centroids;
    std::optional<VisibilityGraph> mpvo;
    std::optional<Convexification> convex;

    explicit Impl(const mesh::TetMesh& m) : mesh(m) {}

    VisibilityOrder centroidOrder(const SortView& view) {
        if (centroids.empty()) {
            centroids.resize(mesh.tetCount());
            for (std::size_t t = 0; t < mesh.tetCount(); ++t) {
                Vec3 c{0, 0, 0};
                for (const std::uint32_t v : mesh.tets[t])
                    c = add(c, mesh.points[v]);
                centroids[t] = scale(c, 0.25);
            }
        }
        // Farthest first: ascending keys of minus the distance (along the view, or squared from the eye).
        std::vector<std::uint32_t> keys(centroids.size()), order(centroids.size());
        for (std::size_t t = 0; t < centroids.size(); ++t) {
            const Vec3& c = centroids[t];
            const Vec3 d = sub(c, view.eye);
            const double dist = view.perspective ? dot(d, d) : dot(c, view.direction);
            keys[t] = floatSortKey(static_cast<float>(-dist));
            order[t] = static_cast<std::uint32_t>(t);
        }
        radixSortReference(keys, order);
        VisibilityOrder out;
        out.tets = std::move(order);
        return out;
    }

    Convexification& convexification() {
        if (!convex) convex = convexify(mesh);
        return *convex;
    }
};

VisibilitySorter::VisibilitySorter(const mesh::TetMesh& mesh) : impl_(std::make_unique<Impl>(mesh)) {}
VisibilitySorter::~VisibilitySorter() = default;

VisibilityOrder VisibilitySorter::sort(const SortView& view, MeshSort method) {
    if (method == MeshSort::Centroid) {
        Stopwatch sw;
        VisibilityOrder out = impl_->centroidOrder(view);
        out.seconds = sw.milliseconds() * 1e-3;
        return out;
    }
    // The graph is built once (not timed here: Convexification::stats.seconds has the convexification's time).
    if (method == MeshSort::Mpvo && !impl_->mpvo) impl_->mpvo = meshAdjacencyGraph(impl_->mesh);
    const VisibilityGraph& g = method == MeshSort::Mpvo ? *impl_->mpvo : impl_->convexification().graph;
    Stopwatch sw;
    GraphOrder order = sortGraph(g, view);
    VisibilityOrder out;
    out.tets = std::move(order.tets);
    out.cyclesBroken = order.cyclesBroken;
    out.seconds = sw.milliseconds() * 1e-3;
    return out;
}

const ConvexificationStats& VisibilitySorter::convexification() {
    return impl_->convexification().stats;
}

} // namespace volcl
