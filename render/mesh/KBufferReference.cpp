// C++ mirror of cl/mesh/mesh_kbuffer.cl, operation for operation in float.
#include "render/mesh/KBufferReference.hpp"

#include "core/Error.hpp"
#include "render/mesh/RadixSort.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl {
namespace {
constexpr float kNear = 1e-4f;
} // namespace

KBufferProjected kbufferMirrorProject(const cl_float4& p, const VolclKBufferParams& P) {
    const float rx = p.s[0] - P.eye[0], ry = p.s[1] - P.eye[1], rz = p.s[2] - P.eye[2];
    const float z = rx * P.forward[0] + ry * P.forward[1] + rz * P.forward[2];
    const float xr = rx * P.right[0] + ry * P.right[1] + rz * P.right[2];
    const float yu = rx * P.up[0] + ry * P.up[1] + rz * P.up[2];
    float nx, ny, w = 1.0f;
    if (P.perspective) {
        if (z > kNear) {
            w = 1.0f / z;
            nx = xr / (z * P.halfX);
            ny = yu / (z * P.halfY);
        } else {
            w = 0.0f;
            nx = 0.0f;
            ny = 0.0f;
        }
    } else {
        nx = xr / P.halfX;
        ny = yu / P.halfY;
    }
    const float sx = (nx + 1.0f) * (0.5f * float(P.width)) - 0.5f;
    const float sy = (1.0f - ny) * (0.5f * float(P.height)) - 0.5f;
    return {sx, sy, z, w};
}

namespace {

std::array<float, 4> bilinear(const std::vector<float>& table, unsigned n, unsigned k, float u, float v) {
    const float hi = float(n - 1);
    u = std::clamp(u, 0.0f, hi);
    v = std::clamp(v, 0.0f, hi);
    const unsigned i0 = std::min(unsigned(u), n - 2), j0 = std::min(unsigned(v), n - 2);
    const float fu = u - float(i0), fv = v - float(j0);
    const float* row0 = table.data() + ((std::size_t(k) * n + i0) * n) * 4;
    const float* row1 = row0 + std::size_t(n) * 4;
    std::array<float, 4> out{};
    for (int c = 0; c < 4; ++c) {
        const float a = row0[j0 * 4 + c] + fv * (row0[(j0 + 1) * 4 + c] - row0[j0 * 4 + c]);
        const float b = row1[j0 * 4 + c] + fv * (row1[(j0 + 1) * 4 + c] - row1[j0 * 4 + c]);
        out[c] = a + fu * (b - a);
    }
    return out;
}

} // namespace

std::array<float, 4> kbufferMirrorPreint(const std::vector<float>& table, const VolclKBufferParams& P,
                                         float sf, float sb, float len) {
    const VolclTfParams& T = P.tf;
    const float u = (sf - T.domainLo) * P.tableScale, v = (sb - T.domainLo) * P.tableScale;
    const float kf = len * P.lengthScale - 1.0f;
    std::array<float, 4> e;
    float tableLen = len;
    if (kf <= 0.0f) {
        e = bilinear(table, T.tableSize, 0, u, v);
        const float w = std::fmax(kf + 1.0f, 0.0f);
        for (float& x : e)
            x = x * w;
    } else if (kf >= float(T.tableLengths - 1)) {
        e = bilinear(table, T.tableSize, T.tableLengths - 1, u, v);
        tableLen = T.tableMaxLength;
    } else {
        const unsigned k0 = unsigned(kf);
        const float fk = kf - float(k0);
        const auto a = bilinear(table, T.tableSize, k0, u, v);
        const auto b = bilinear(table, T.tableSize, k0 + 1, u, v);
        for (int c = 0; c < 4; ++c)
            e[c] = a[c] + fk * (b[c] - a[c]);
    }
    if (len != tableLen) {
        const float a = std::clamp(e[3], 0.0f, 1.0f);
        const float an = a < 1.0f ? 1.0f - std::pow(1.0f - a, len / tableLen) : 1.0f;
        for (int c = 0; c < 3; ++c)
            e[c] = a > 0.0f ? e[c] * (an / a) : e[c] * (len / tableLen);
        e[3] = an;
    }
    return e;
}

namespace {

struct Frag {
    float t, s;
    unsigned f;
    std::uint32_t face; ///< index into the faces (mode iso recomputes the fragment's normal from it)
};

using F3 = std::array<float, 3>;
F3 add3(const F3& a, const F3& b) {
    return {a[0] + b[0], a[1] + b[1], a[2] + b[2]};
}
F3 sub3(const F3& a, const F3& b) {
    return {a[0] - b[0], a[1] - b[1], a[2] - b[2]};
}
F3 mul3(const F3& a, float k) {
    return {a[0] * k, a[1] * k, a[2] * k};
}
float dot3(const F3& a, const F3& b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
float len3(const F3& a) {
    return std::sqrt(dot3(a, a));
}
F3 normalize3(const F3& a) {
    return mul3(a, 1.0f / len3(a));
}
F3 xyz(const float* a) {
    return {a[0], a[1], a[2]};
}

/// cl/common/shading.h's Blinn-Phong (SHADING, no scattering) for straight colour c at x with gradient g.
F3 blinnPhong(const VolclLightingParams& Lp, bool perspective, const F3& eye, const F3& dir, const F3& x,
              const F3& g, const F3& c) {
    const float gl = len3(g);
    F3 N = gl > Lp.gradientMin ? mul3(g, -1.0f / gl) : F3{0, 0, 0};
    const F3 V = mul3(dir, -1.0f);
    if (dot3(N, V) < 0.0f) N = mul3(N, -1.0f);
    F3 diffuse{0, 0, 0}, specular{0, 0, 0};
    for (unsigned i = 0; i < Lp.lightCount; ++i) {
        const float kind = Lp.lightPos[i][3];
        F3 L;
        if (kind == float(VOLCL_LIGHT_POINT) || (kind == float(VOLCL_LIGHT_HEAD) && perspective)) {
            const F3 v = sub3(kind == float(VOLCL_LIGHT_POINT) ? xyz(Lp.lightPos[i]) : eye, x);
            const float d = len3(v);
            L = d > 0.0f ? mul3(v, 1.0f / d) : mul3(dir, -1.0f);
        } else if (kind == float(VOLCL_LIGHT_HEAD)) {
            L = mul3(dir, -1.0f);
        } else {
            L = xyz(Lp.lightPos[i]);
        }
        const F3 lc = xyz(Lp.lightColor[i]);
        if (gl > Lp.gradientMin) {
            const F3 H = normalize3(add3(L, V));
            diffuse = add3(diffuse, mul3(lc, std::fmax(dot3(N, L), 0.0f)));
            specular = add3(specular, mul3(lc, std::pow(std::fmax(dot3(N, H), 0.0f), Lp.shininess)));
        } else {
            diffuse = add3(diffuse, lc);
        }
    }
    F3 out;
    for (int k = 0; k < 3; ++k)
        out[k] = c[k] * (Lp.ambient + Lp.diffuse * diffuse[k]) + Lp.specular * specular[k];
    return out;
}

struct Pixel {
    std::array<float, 4> acc{0, 0, 0, 0};
    bool done = false;
    int count = 0;
    float lastPop = -std::numeric_limits<float>::infinity();
};

class Mirror {
public:
    Mirror(const KBufferMirrorInput& in, KBufferMirrorStats* stats)
        : in_(in), P_(in.params), k_(in.k), stats_(stats), pixels_(std::size_t(P_.width) * P_.height),
          frags_(pixels_.size() * std::size_t(k_)) {}

    void segment(std::size_t pi, const Frag& a, const Frag& b) {
        Pixel& px = pixels_[pi];
        if (stats_) {
            if (a.t < px.lastPop) ++stats_->misorderedPops;
            px.lastPop = a.t;
        }
        if ((a.f & KB_FRAG_EXIT) || (b.f & KB_FRAG_ENTER)) return;
        const float len = (b.t - a.t) * P_.worldScale;
        if (!(len > 0.0f)) return;
        if (in_.iso) {
            isoSegment(pi, a, b);
            return;
        }
        std::array<float, 4> c;
        if (!std::isfinite(a.s) || !std::isfinite(b.s)) { // a NaN cell: kb_composite's NAN_COLOR branch
            const float an = 1.0f - std::exp(-in_.nanColor[3] * len);
            c = {in_.nanColor[0] * an, in_.nanColor[1] * an, in_.nanColor[2] * an, an};
        } else {
            c = kbufferMirrorPreint(*in_.table, P_, a.s, b.s, len);
        }
        const float keep = 1.0f - px.acc[3];
        for (int i = 0; i < 4; ++i)
            px.acc[i] = px.acc[i] + keep * c[i];
    }

    /// kb_frag_normal: the normal of fragment q's face at pixel (fx, fy).
    F3 fragNormal(const Frag& q, float fx, float fy) const {
        const MeshFace& face = in_.faces->faces[q.face];
        const KBufferProjected &a = proj_[face.v[0]], &b = proj_[face.v[1]], &c = proj_[face.v[2]];
        float wa = (c.x - b.x) * (fy - b.y) - (c.y - b.y) * (fx - b.x);
        float wb = (a.x - c.x) * (fy - c.y) - (a.y - c.y) * (fx - c.x);
        float wc = (b.x - a.x) * (fy - a.y) - (b.y - a.y) * (fx - a.x);
        if (P_.perspective) {
            wa *= a.w;
            wb *= b.w;
            wc *= c.w;
        }
        const float sum = wa + wb + wc;
        const auto& n = *in_.normals;
        F3 r;
        for (int k = 0; k < 3; ++k)
            r[k] = (wa * n[face.v[0]].s[k] + wb * n[face.v[1]].s[k] + wc * n[face.v[2]].s[k]) / sum;
        return r;
    }

    /// kb_iso_segment: the iso-surfaces the segment a -> b of pixel pi crosses, in ray order.
    void isoSegment(std::size_t pi, const Frag& a, const Frag& b) {
        Pixel& px = pixels_[pi];
        const VolclIsoParams& I = in_.isoParams;
        std::vector<std::pair<float, int>> cross;
        for (int i = 0; i < int(I.count); ++i) {
            const float v = I.value[i];
            if ((a.s >= v) != (b.s >= v)) {
                const float u = std::clamp((v - a.s) / (b.s - a.s), 0.0f, 1.0f);
                std::size_t j = cross.size();
                cross.push_back({u, i});
                while (j > 0 && cross[j - 1].first > u) { // the kernel's insertion: equal u keep their order
                    std::swap(cross[j], cross[j - 1]);
                    --j;
                }
            }
        }
        if (cross.empty()) return;
        const float fx = float(pi % P_.width), fy = float(pi / P_.width);
        F3 dir{}, origin{}, np{}, nq{};
        const F3 eye = xyz(P_.eye);
        if (in_.shading) {
            const float ndcX = 2.0f * (fx + 0.5f) / float(P_.width) - 1.0f;
            const float ndcY = 1.0f - 2.0f * (fy + 0.5f) / float(P_.height);
            const F3 side = add3(mul3(xyz(P_.right), ndcX * P_.halfX), mul3(xyz(P_.up), ndcY * P_.halfY));
            dir = P_.perspective ? normalize3(add3(xyz(P_.forward), side)) : xyz(P_.forward);
            origin = P_.perspective ? eye : add3(eye, side);
            np = fragNormal(a, fx, fy);
            nq = fragNormal(b, fx, fy);
        }
        for (const auto& [u, i] : cross) {
            const float ia = I.color[i][3];
            F3 rgb{I.color[i][0], I.color[i][1], I.color[i][2]};
            if (in_.shading) {
                const F3 x = add3(origin, mul3(dir, a.t + (b.t - a.t) * u));
                rgb = blinnPhong(in_.lighting, P_.perspective != 0, eye, dir, x,
                                 add3(np, mul3(sub3(nq, np), u)), rgb);
            }
            const float keep = 1.0f - px.acc[3];
            for (int k = 0; k < 3; ++k)
                px.acc[k] += keep * (rgb[k] * ia);
            px.acc[3] += keep * ia;
        }
    }

    /// Stores `in` among the first n (sorted) entries of kb: after every entry not farther (the kernel's ring).
    static void place(Frag* kb, int n, const Frag& in) {
        int j = n;
        while (j > 0 && kb[j - 1].t > in.t) {
            kb[j] = kb[j - 1];
            --j;
        }
        kb[j] = in;
    }

    void insert(std::size_t pi, const Frag& in) {
        Pixel& px = pixels_[pi];
        Frag* kb = &frags_[pi * std::size_t(k_)]; // sorted by distance, equal distances in arrival order
        if (stats_) ++stats_->fragments;
        if (px.count < k_) {
            place(kb, px.count++, in);
            return;
        }
        if (stats_) ++stats_->overflowPops;
        if (in.t < kb[0].t) {
            segment(pi, in, kb[0]);
        } else {
            segment(pi, kb[0], in.t < kb[1].t ? in : kb[1]);
            std::copy(kb + 1, kb + k_, kb);
            place(kb, k_ - 1, in);
        }
        if (px.acc[3] >= P_.earlyTermination) px.done = true;
    }

    void flush(std::size_t pi) {
        Pixel& px = pixels_[pi];
        const Frag* kb = &frags_[pi * std::size_t(k_)];
        for (int i = 1; i < px.count && px.acc[3] < P_.earlyTermination; ++i)
            segment(pi, kb[i - 1], kb[i]);
    }

    ImageBuffer run() {
        const auto& g = *in_.geometry;
        std::vector<KBufferProjected>& proj = proj_;
        proj.resize(g.points.size());
        for (std::size_t i = 0; i < proj.size(); ++i)
            proj[i] = kbufferMirrorProject(g.points[i], P_);
        const std::vector<std::uint32_t> order = in_.order ? *in_.order : kbufferMirrorOrder(in_);
        const auto& faces = in_.faces->faces;
        const auto& sc = *in_.scalars;
        const int W = int(P_.width), H = int(P_.height);
        for (std::uint32_t fi : order) {
            const MeshFace& face = faces[fi];
            const std::uint32_t ia = face.v[0], ib = face.v[1], ic = face.v[2];
            const KBufferProjected a = proj[ia], b = proj[ib], c = proj[ic];
            const float orient = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
            if (!(orient != 0.0f && a.w != 0.0f && b.w != 0.0f && c.w != 0.0f)) continue;
            const float sg = orient > 0.0f ? 1.0f : -1.0f;
            const unsigned fl = face.boundary ? (orient < 0.0f ? KB_FRAG_ENTER : KB_FRAG_EXIT) : 0u;
            const Edge ea = makeEdge(b, ib, c, ic, sg), eb = makeEdge(c, ic, a, ia, sg),
                       ec = makeEdge(a, ia, b, ib, sg);
            const float sa = sc[ia], sb = sc[ib], scc = sc[ic];
            const int x0 = int(std::ceil(std::fmax(std::fmin(std::fmin(a.x, b.x), c.x), 0.0f)));
            const int x1 = int(std::floor(std::fmin(std::fmax(std::fmax(a.x, b.x), c.x), float(W - 1))));
            const int y0 = int(std::ceil(std::fmax(std::fmin(std::fmin(a.y, b.y), c.y), 0.0f)));
            const int y1 = int(std::floor(std::fmin(std::fmax(std::fmax(a.y, b.y), c.y), float(H - 1))));
            for (int y = y0; y <= y1; ++y) {
                const float fy = float(y);
                for (int x = x0; x <= x1; ++x) {
                    const std::size_t pi = std::size_t(y) * W + x;
                    if (pixels_[pi].done) continue;
                    if (stats_) ++stats_->pixelTests;
                    const float fx = float(x);
                    const float wa = ea.sigma * edge(ea, fx, fy);
                    const float wb = eb.sigma * edge(eb, fx, fy);
                    const float wc = ec.sigma * edge(ec, fx, fy);
                    if (!(wa > 0.0f || (wa == 0.0f && ea.tie))) continue;
                    if (!(wb > 0.0f || (wb == 0.0f && eb.tie))) continue;
                    if (!(wc > 0.0f || (wc == 0.0f && ec.tie))) continue;
                    const float sum = wa + wb + wc;
                    const float la = wa / sum, lb = wb / sum, lc = wc / sum;
                    float t, s;
                    if (P_.perspective) {
                        const float q = la * a.w + lb * b.w + lc * c.w;
                        const float z = 1.0f / q;
                        s = (la * (sa * a.w) + lb * (sb * b.w) + lc * (scc * c.w)) * z;
                        const float ndcX = 2.0f * (fx + 0.5f) / float(P_.width) - 1.0f;
                        const float ndcY = 1.0f - 2.0f * (fy + 0.5f) / float(P_.height);
                        const float dx = ndcX * P_.halfX, dy = ndcY * P_.halfY;
                        t = z * std::sqrt(1.0f + dx * dx + dy * dy);
                    } else {
                        t = la * a.z + lb * b.z + lc * c.z;
                        s = la * sa + lb * sb + lc * scc;
                    }
                    insert(pi, {t, s, fl, fi});
                }
            }
        }
        ImageBuffer img(W, H, {"R", "G", "B", "A"});
        for (std::size_t pi = 0; pi < pixels_.size(); ++pi) {
            if (!pixels_[pi].done) flush(pi);
            for (int c = 0; c < 4; ++c)
                img.pixels[pi * 4 + c] = pixels_[pi].acc[c];
        }
        return img;
    }

private:
    struct Edge {
        float px, py, qx, qy, sigma;
        bool tie;
    };
    static float edge(const Edge& e, float x, float y) {
        return (e.qx - e.px) * (y - e.py) - (e.qy - e.py) * (x - e.px);
    }
    static Edge makeEdge(const KBufferProjected& u, std::uint32_t iu, const KBufferProjected& v,
                         std::uint32_t iv, float orientSign) {
        Edge e;
        float s;
        if (iu < iv) {
            e = {u.x, u.y, v.x, v.y, 0.0f, false};
            s = 1.0f;
        } else {
            e = {v.x, v.y, u.x, u.y, 0.0f, false};
            s = -1.0f;
        }
        e.sigma = orientSign * s;
        const float dx = e.qx - e.px, dy = e.qy - e.py;
        const float side = (dy > 0.0f || (dy == 0.0f && dx < 0.0f)) ? 1.0f : -1.0f;
        e.tie = e.sigma * side > 0.0f;
        return e;
    }

    const KBufferMirrorInput& in_;
    VolclKBufferParams P_;
    int k_;
    KBufferMirrorStats* stats_;
    std::vector<Pixel> pixels_;
    std::vector<Frag> frags_;
    std::vector<KBufferProjected> proj_;
};

} // namespace

std::vector<std::uint32_t> kbufferMirrorOrder(const KBufferMirrorInput& in) {
    const VolclKBufferParams& P = in.params;
    const auto& pts = in.geometry->points;
    const auto& faces = in.faces->faces;
    std::vector<std::uint32_t> keys(P.faceCount), vals(P.faceCount);
    for (std::uint32_t i = 0; i < P.faceCount; ++i) {
        const auto& p0 = pts[faces[i].v[0]];
        const auto& p1 = pts[faces[i].v[1]];
        const auto& p2 = pts[faces[i].v[2]];
        float depth;
        if (P.perspective) {
            const float cx = (p0.s[0] + p1.s[0] + p2.s[0]) / 3.0f - P.eye[0];
            const float cy = (p0.s[1] + p1.s[1] + p2.s[1]) / 3.0f - P.eye[1];
            const float cz = (p0.s[2] + p1.s[2] + p2.s[2]) / 3.0f - P.eye[2];
            depth = std::sqrt(cx * cx + cy * cy + cz * cz);
        } else {
            depth = (kbufferMirrorProject(p0, P).z + kbufferMirrorProject(p1, P).z +
                     kbufferMirrorProject(p2, P).z) /
                    3.0f;
        }
        keys[i] = floatSortKey(depth);
        vals[i] = i;
    }
    radixSortReference(keys, vals);
    return vals;
}

ImageBuffer kbufferMirrorRender(const KBufferMirrorInput& in, KBufferMirrorStats* stats) {
    if (!in.geometry || !in.scalars || !in.faces || !in.table || (in.iso && in.shading && !in.normals))
        throw Error("internal: incomplete k-buffer mirror input");
    if (in.order && (in.order->size() != in.params.faceCount ||
                     std::any_of(in.order->begin(), in.order->end(),
                                 [&](std::uint32_t f) { return f >= in.params.faceCount; })))
        throw Error("internal: the k-buffer mirror's face order is not one of the faces drawn");
    if (in.k < kKBufferMinK || in.k > kKBufferMirrorMaxK)
        throw UsageError("k-buffer mirror: k must be 2.." + std::to_string(kKBufferMirrorMaxK));
    if (stats) *stats = {};
    Mirror m(in, stats);
    return m.run();
}

} // namespace volcl
