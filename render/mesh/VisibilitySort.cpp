// Visibility orders of a tetrahedral mesh's cells: the centroid sort (MPVO and the convexified sort fall back to
// it in this implementation).
#include "render/mesh/VisibilitySort.hpp"

#include "core/Error.hpp"
#include "core/runtime/Timing.hpp"

#include <algorithm>
#include <numeric>
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
    return "centroid";
}

MeshSort parseMeshSort(std::string_view s) {
    if (s == "centroid") return MeshSort::Centroid;
    if (s == "mpvo") return MeshSort::Mpvo;
    if (s == "convexified") return MeshSort::Convexified;
    throw UsageError("render.sort '" + std::string(s) +
                     "' is unknown (expected centroid, mpvo, convexified)");
}

struct VisibilitySorter::Impl {
    const mesh::TetMesh& mesh;
    std::vector<Vec3> centroids;
};

VisibilitySorter::VisibilitySorter(const mesh::TetMesh& mesh)
    : impl_(std::make_unique<Impl>(Impl{mesh, {}})) {
    impl_->centroids.resize(mesh.tets.size());
    for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
        Vec3 c{0, 0, 0};
        for (const auto v : mesh.tets[t])
            c = add(c, mesh.points[v]);
        impl_->centroids[t] = scale(c, 0.25);
    }
}

VisibilitySorter::~VisibilitySorter() = default;

VisibilityOrder VisibilitySorter::sort(const SortView& view, MeshSort method) {
    (void)method; // every method sorts by centroid here
    Stopwatch sw;
    const std::vector<Vec3>& c = impl_->centroids;
    std::vector<double> key(c.size());
    for (std::size_t t = 0; t < c.size(); ++t)
        key[t] = view.perspective ? norm(sub(c[t], view.eye)) : dot(c[t], view.direction);
    VisibilityOrder order;
    order.tets.resize(c.size());
    std::iota(order.tets.begin(), order.tets.end(), 0u);
    std::stable_sort(order.tets.begin(), order.tets.end(),
                     [&](std::uint32_t a, std::uint32_t b) { return key[a] > key[b]; });
    order.seconds = sw.milliseconds() / 1000.0;
    return order;
}

} // namespace volcl
