// The ray oracle of visibility orders: brute-force ray-tet clipping, pairs of consecutive tets per ray.
#include "render/mesh/VisibilityOracle.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl {

bool tetRayInterval(const mesh::TetMesh& m, std::size_t t, const Vec3& o, const Vec3& d, double& t0,
                    double& t1) {
    t0 = -std::numeric_limits<double>::infinity();
    t1 = std::numeric_limits<double>::infinity();
    const auto& v = m.tets[t];
    for (int i = 0; i < 4; ++i) {
        const Vec3 a = m.points[v[(i + 1) % 4]], b = m.points[v[(i + 2) % 4]], c = m.points[v[(i + 3) % 4]];
        Vec3 n = cross(sub(b, a), sub(c, a));
        if (dot(n, sub(m.points[v[i]], a)) < 0.0) n = scale(n, -1.0); // toward the opposite vertex
        // Inside: dot(n, o + t d - a) >= 0.
        const double g0 = dot(n, sub(o, a)), g1 = dot(n, d);
        if (g1 == 0.0) {
            if (g0 < 0.0) return false;
            continue;
        }
        const double tc = -g0 / g1;
        if (g1 > 0.0)
            t0 = std::max(t0, tc);
        else
            t1 = std::min(t1, tc);
    }
    return t1 > t0;
}

OrderCheck checkOrderAlongRays(const mesh::TetMesh& m, const std::vector<std::uint32_t>& order,
                               const SortView& view, int raysPerAxis) {
    std::vector<std::size_t> position(m.tetCount());
    for (std::size_t i = 0; i < order.size(); ++i)
        position[order[i]] = i;
    const Vec3 lo = m.boundsMin, hi = m.boundsMax;
    const Vec3 centre = scale(add(lo, hi), 0.5);
    const double radius = 0.5 * norm(sub(hi, lo));
    const double tol = 1e-9 * radius;
    OrderCheck count;
    struct Hit {
        double t0, t1;
        std::uint32_t tet;
    };
    std::vector<Hit> hits;
    const int n = raysPerAxis;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            Vec3 o, d;
            if (view.perspective) {
                // Fibonacci sphere: every direction from the eye.
                const double k = double(i * n + j) + 0.5, total = double(n * n);
                const double z = 1.0 - 2.0 * k / total, r = std::sqrt(std::max(0.0, 1.0 - z * z));
                const double phi = k * 2.399963229728653;
                o = view.eye;
                d = {r * std::cos(phi), r * std::sin(phi), z};
            } else {
                d = normalized(view.direction);
                const Vec3 u =
                    normalized(std::abs(d[0]) < 0.9 ? cross(d, Vec3{1, 0, 0}) : cross(d, Vec3{0, 1, 0}));
                const Vec3 w = cross(d, u);
                const double a = radius * (2.0 * (i + 0.5) / n - 1.0),
                             b = radius * (2.0 * (j + 0.5) / n - 1.0);
                o = add(sub(centre, scale(d, 2.0 * radius)), add(scale(u, a), scale(w, b)));
            }
            hits.clear();
            for (std::size_t t = 0; t < m.tetCount(); ++t) {
                double t0 = 0, t1 = 0;
                if (!tetRayInterval(m, t, o, d, t0, t1)) continue;
                if (view.perspective) t0 = std::max(t0, 0.0);
                if (t1 - t0 > tol) hits.push_back({t0, t1, static_cast<std::uint32_t>(t)});
            }
            ++count.rays;
            std::sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) { return a.t0 < b.t0; });
            for (std::size_t a = 0; a < hits.size(); ++a)
                for (std::size_t b = a + 1; b < hits.size(); ++b) {
                    if (hits[a].t1 > hits[b].t0 + tol)
                        continue; // they overlap along the ray: no order needed
                    ++count.pairs;
                    if (position[hits[b].tet] > position[hits[a].tet]) ++count.violations;
                }
        }
    return count;
}

} // namespace volcl
