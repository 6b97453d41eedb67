// The cut-border machine's shared state: border FIFO and glue table, edges, recency, candidate ranking.
#include "meshcodec/CutBorder.hpp"

#include <algorithm>

namespace volcl::meshcodec {

CutBorder::CutBorder(std::size_t pointCount) {
    adjacency_.reserve(pointCount);
    stamp_.reserve(pointCount);
    origins_.reserve(pointCount);
    seen_.reserve(pointCount);
    count_.reserve(pointCount);
}

CutBorder::Key CutBorder::keyOf(std::uint32_t a, std::uint32_t b, std::uint32_t c) noexcept {
    if (a > b) std::swap(a, b);
    if (b > c) std::swap(b, c);
    if (a > b) std::swap(a, b);
    return {a, b, c};
}

const BorderFace* CutBorder::popFace() {
    while (head_ < faces_.size()) {
        const BorderFace& f = faces_[head_++];
        if (f.alive) return &f;
    }
    return nullptr;
}

std::uint32_t CutBorder::newVertex(const VertexOrigin& origin) {
    const auto id = static_cast<std::uint32_t>(origins_.size());
    origins_.push_back(origin);
    adjacency_.emplace_back();
    stamp_.push_back(0);
    positions_.push_back({0, 0, 0});
    boundary_.push_back(0);
    seen_.push_back(0);
    count_.push_back(0);
    return id;
}

void CutBorder::addEdge(std::uint32_t u, std::uint32_t v) {
    std::vector<std::uint32_t>& list = adjacency_[u];
    if (std::find(list.begin(), list.end(), v) != list.end()) return;
    list.push_back(v);
    adjacency_[v].push_back(u);
}

void CutBorder::glueOrAdd(std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t opposite,
                          std::uint32_t owner) {
    const auto [it, inserted] = open_.try_emplace(keyOf(a, b, c), static_cast<std::uint32_t>(faces_.size()));
    if (!inserted) { // the triangle is met from its second side: it leaves the border
        faces_[it->second].alive = false;
        open_.erase(it);
        return;
    }
    faces_.push_back({{a, b, c}, opposite, owner, true});
}

void CutBorder::addTet(const mesh::Tet& t, const BorderFace* across) {
    const auto owner = static_cast<std::uint32_t>(tets_.size());
    tets_.push_back(t);
    for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j)
            addEdge(t[i], t[j]);
    for (int i = 0; i < 4; ++i)
        stamp_[t[i]] = owner + 1;
    if (across) { // face 3 of t is the attaching face, seen from the other side
        const auto idx = static_cast<std::size_t>(across - faces_.data());
        open_.erase(keyOf(across->v[0], across->v[1], across->v[2]));
        faces_[idx].alive = false;
    }
    for (unsigned f = 0; f < 4; ++f) {
        if (across && f == 3) continue;
        const auto& lv = mesh::kTetFaceVertices[f];
        glueOrAdd(t[lv[0]], t[lv[1]], t[lv[2]], t[f], owner);
    }
}

void CutBorder::rankCandidates(const BorderFace& f, std::vector<Candidate>& out) {
    out.clear();
    if (++round_ == 0) { // the marks wrapped: start them afresh
        std::fill(seen_.begin(), seen_.end(), 0);
        round_ = 1;
    }
    for (const std::uint32_t x : {f.v[0], f.v[1], f.v[2], f.opposite})
        if (x != kNoVertex) seen_[x] = round_, count_[x] = 0xFFFFFFFFu; // excluded
    for (const std::uint32_t x : f.v)
        for (const std::uint32_t n : adjacency_[x]) {
            if (seen_[n] != round_) {
                seen_[n] = round_;
                count_[n] = 0;
                out.push_back({n, 0, stamp_[n], 0});
            }
            if (count_[n] != 0xFFFFFFFFu) ++count_[n];
        }
    // Border faces the candidate's tet (a, b, c, v) would close: its face over edge (x, y) of the border
    // face is (x, y, v) in that cyclic order, and a border triangle on those vertices wound (y, x, v) glues
    // to it; such a candidate is the likeliest fourth vertex. A border triangle wound (x, y, v) lies on the
    // same side: that tet would overlap it, so the candidate goes last (score 0).
    // Geometry: the tet (a, b, c, v) must be positively oriented (v beyond the face's plane, seen from the
    // owner), and v is most likely near the owner's fourth vertex reflected through the face's centroid.
    const mesh::Point3 &a = positions_[f.v[0]], &b = positions_[f.v[1]], &c3 = positions_[f.v[2]];
    const mesh::Point3& p = positions_[f.opposite];
    double ab[3], ac[3], predicted[3];
    for (int k = 0; k < 3; ++k) {
        ab[k] = b[k] - a[k];
        ac[k] = c3[k] - a[k];
        predicted[k] = 2.0 * (a[k] + b[k] + c3[k]) / 3.0 - p[k];
    }
    const double normal[3] = {ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2],
                              ab[0] * ac[1] - ab[1] * ac[0]};
    for (Candidate& c : out) {
        const mesh::Point3& q = positions_[c.vertex];
        const double side = normal[0] * (q[0] - a[0]) + normal[1] * (q[1] - a[1]) + normal[2] * (q[2] - a[2]);
        c.distance = 0;
        for (int k = 0; k < 3; ++k)
            c.distance += (q[k] - predicted[k]) * (q[k] - predicted[k]);
        const std::uint32_t edges = count_[c.vertex];
        std::uint32_t closed = 0, clashes = 0;
        if (edges >= 2)
            for (int e = 0; e < 3; ++e) {
                const std::uint32_t x = f.v[e], y = f.v[(e + 1) % 3];
                const auto it = open_.find(keyOf(x, y, c.vertex));
                if (it == open_.end()) continue;
                const auto& w = faces_[it->second].v;
                const bool glues =
                    (w[0] == y && w[1] == x) || (w[1] == y && w[2] == x) || (w[2] == y && w[0] == x);
                ++(glues ? closed : clashes);
            }
        c.score = clashes || !(side > 0) ? 0 : closed * 4 + edges;
    }
    const auto better = [](const Candidate& l, const Candidate& r) {
        if (l.score != r.score) return l.score > r.score;
        if (l.distance != r.distance) return l.distance < r.distance;
        if (l.stamp != r.stamp) return l.stamp > r.stamp;
        return l.vertex > r.vertex;
    };
    if (out.size() > kMaxCandidates) {
        std::partial_sort(out.begin(), out.begin() + kMaxCandidates, out.end(), better);
        out.resize(kMaxCandidates);
    } else {
        std::sort(out.begin(), out.end(), better);
    }
}

} // namespace volcl::meshcodec
