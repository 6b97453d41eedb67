// C++ mirror of cl/mesh/mesh_pt.cl, operation for operation in float.
#include "render/mesh/PtReference.hpp"

#include "core/Error.hpp"
#include "core/runtime/ParallelFor.hpp"
#include "render/mesh/KBufferReference.hpp"
#include "render/mesh/MeshGeometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl {
namespace {

struct Cell {
    std::array<std::array<float, 4>, 4> plane;
    std::array<float, 4> field;
    int x0 = 1, y0 = 1, x1 = 0, y1 = 0; ///< pixel rectangle, empty when x0 > x1
};

float dot3(const std::array<float, 4>& p, const float o[3]) {
    return p[0] * o[0] + p[1] * o[1] + p[2] * o[2];
}

/// mesh_pt.cl's pt_tet_rects: the pixel rectangle of the cell's projection.
void cellRect(Cell& c, const std::array<KBufferProjected, 4>& q, const VolclKBufferParams& P) {
    const float zMax = std::fmax(std::fmax(q[0].z, q[1].z), std::fmax(q[2].z, q[3].z));
    if (!(zMax > 0.0f)) return;
    float x0 = 0.0f, y0 = 0.0f, x1 = float(P.width - 1), y1 = float(P.height - 1);
    if (!P.perspective || (q[0].w != 0.0f && q[1].w != 0.0f && q[2].w != 0.0f && q[3].w != 0.0f)) {
        float lx = q[0].x, hx = q[0].x, ly = q[0].y, hy = q[0].y;
        for (int i = 1; i < 4; ++i) {
            lx = std::fmin(lx, q[i].x);
            hx = std::fmax(hx, q[i].x);
            ly = std::fmin(ly, q[i].y);
            hy = std::fmax(hy, q[i].y);
        }
        x0 = std::ceil(std::fmax(lx, 0.0f));
        x1 = std::floor(std::fmin(hx, float(P.width - 1)));
        y0 = std::ceil(std::fmax(ly, 0.0f));
        y1 = std::floor(std::fmin(hy, float(P.height - 1)));
    }
    if (x0 <= x1 && y0 <= y1) {
        c.x0 = int(x0);
        c.x1 = int(x1);
        c.y0 = int(y0);
        c.y1 = int(y1);
    }
}

} // namespace

ImageBuffer ptMirrorRender(const PtMirrorInput& in) {
    if (!in.mesh || !in.geometry || !in.order || !in.table) throw Error("ptMirrorRender: missing input");
    const mesh::TetMesh& mesh = *in.mesh;
    const KBufferGeometry& g = *in.geometry;
    const VolclKBufferParams& P = in.params;
    const std::size_t nt = mesh.tets.size();
    std::vector<Cell> cells(nt);
    parallelFor(nt, 0u, [&](std::size_t t) {
        const mesh_detail::NormalisedTet r = mesh_detail::normalisedTet(mesh, t, g.centre, g.scale);
        Cell& c = cells[t];
        for (int f = 0; f < 4; ++f)
            c.plane[f] = {float(r.normal[f][0]), float(r.normal[f][1]), float(r.normal[f][2]),
                          float(r.offset[f])};
        c.field = {float(r.gradient[0]), float(r.gradient[1]), float(r.gradient[2]), float(r.value)};
        std::array<KBufferProjected, 4> q;
        for (int i = 0; i < 4; ++i)
            q[i] = kbufferMirrorProject(g.points[mesh.tets[t][i]], P);
        cellRect(c, q, P);
    });
    const int W = int(P.width), H = int(P.height);
    ImageBuffer img;
    img.width = W;
    img.height = H;
    img.channels = {"R", "G", "B", "A"};
    img.pixels.assign(std::size_t(W) * H * 4, 0.0f);
    std::vector<std::uint8_t> done(std::size_t(W) * H, 0);
    const float eye[3] = {P.eye[0], P.eye[1], P.eye[2]};
    const float fw[3] = {P.forward[0], P.forward[1], P.forward[2]};
    const float rt[3] = {P.right[0], P.right[1], P.right[2]};
    const float up[3] = {P.up[0], P.up[1], P.up[2]};
    const std::vector<std::uint32_t>& order = *in.order;
    for (std::size_t k = order.size(); k-- > 0;) {
        const Cell& c = cells[order[k]];
        for (int y = c.y0; y <= c.y1; ++y) {
            const float ndcY = 1.0f - 2.0f * (float(y) + 0.5f) / float(P.height);
            for (int x = c.x0; x <= c.x1; ++x) {
                const std::size_t li = std::size_t(y) * W + std::size_t(x);
                if (done[li]) continue;
                const float ndcX = 2.0f * (float(x) + 0.5f) / float(P.width) - 1.0f;
                float o[3], d[3];
                for (int a = 0; a < 3; ++a) {
                    o[a] = eye[a];
                    d[a] = fw[a];
                }
                const float sx = ndcX * P.halfX, sy = ndcY * P.halfY;
                if (P.perspective) {
                    float v[3];
                    for (int a = 0; a < 3; ++a)
                        v[a] = (fw[a] + sx * rt[a]) + sy * up[a];
                    const float len = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
                    for (int a = 0; a < 3; ++a)
                        d[a] = v[a] / len;
                } else {
                    for (int a = 0; a < 3; ++a)
                        o[a] = (eye[a] + sx * rt[a]) + sy * up[a];
                }
                const float base = std::fmax(-(o[0] * d[0] + o[1] * d[1] + o[2] * d[2]), 0.0f);
                for (int a = 0; a < 3; ++a)
                    o[a] = o[a] + base * d[a];
                float lo = -base, hi = std::numeric_limits<float>::infinity();
                for (unsigned i = 0; i < in.clip.count; ++i) {
                    const float* pl = in.clip.plane[i];
                    const float a = pl[0] * o[0] + pl[1] * o[1] + pl[2] * o[2] + pl[3];
                    const float b = pl[0] * d[0] + pl[1] * d[1] + pl[2] * d[2];
                    if (b > 0.0f)
                        lo = std::fmax(lo, -a / b);
                    else if (b < 0.0f)
                        hi = std::fmin(hi, -a / b);
                    else if (a < 0.0f)
                        hi = -std::numeric_limits<float>::infinity();
                }
                lo = std::fmax(lo, -base);
                for (const auto& p : c.plane) {
                    const float a = dot3(p, o) + p[3], b = dot3(p, d);
                    if (b > 0.0f)
                        hi = std::fmin(hi, -a / b);
                    else if (b < 0.0f)
                        lo = std::fmax(lo, -a / b);
                    else if (a > 0.0f ||
                             (a == 0.0f && (p[0] < 0.0f || (p[0] == 0.0f &&
                                                            (p[1] < 0.0f || (p[1] == 0.0f && p[2] < 0.0f))))))
                        hi = -std::numeric_limits<float>::infinity();
                }
                if (!(hi > lo)) continue;
                const float len = (hi - lo) * P.worldScale;
                float pf[3], pb[3];
                for (int a = 0; a < 3; ++a) {
                    pf[a] = o[a] + lo * d[a];
                    pb[a] = o[a] + hi * d[a];
                }
                const float sf = dot3(c.field, pf) + c.field[3], sb = dot3(c.field, pb) + c.field[3];
                std::array<float, 4> col;
                if (!std::isfinite(sf) || !std::isfinite(sb)) {
                    if (!in.nanCells) continue;
                    const float a = 1.0f - std::exp(-in.nanColor[3] * len);
                    col = {in.nanColor[0] * a, in.nanColor[1] * a, in.nanColor[2] * a, a};
                } else {
                    col = kbufferMirrorPreint(*in.table, P, sf, sb, len);
                }
                float* acc = img.pixels.data() + 4 * li;
                const float keep = 1.0f - acc[3];
                for (int ch = 0; ch < 4; ++ch)
                    acc[ch] = acc[ch] + keep * col[ch];
                if (acc[3] >= P.earlyTermination) done[li] = 1;
            }
        }
    }
    return img;
}

} // namespace volcl
