// The mesh's exact reference: BVH entry, face-adjacent walk, exact segment integrals in double (every mode).
#include "render/mesh/MeshReference.hpp"

#include "core/Error.hpp"
#include "preintegration/Reference.hpp"
#include "render/FrameParams.hpp"
#include "render/mesh/MeshGeometry.hpp"
#include "render/mesh/VertexNormals.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace volcl {

WorldBox meshBounds(const mesh::TetMesh& m) {
    return {m.boundsMin, sub(m.boundsMax, m.boundsMin)};
}

ValueRange meshValueRange(const mesh::TetMesh& m) {
    return {double(m.valueMin), double(m.valueMax)};
}

bool tetHasNonFinite(const mesh::TetMesh& m, std::size_t tet) {
    for (std::uint32_t v : m.tets[tet])
        if (!std::isfinite(m.scalars[v])) return true;
    return false;
}

bool meshHasNonFinite(const mesh::TetMesh& m) {
    for (std::size_t t = 0; t < m.tets.size(); ++t)
        if (tetHasNonFinite(m, t)) return true;
    return false;
}

EffectPlan planMeshEffects(const Scene& scene, const mesh::TetMesh& m) {
    Scene s = scene;
    std::vector<std::string> dropped;
    if (s.effects.shadows) {
        dropped.push_back("shadows: not available on meshes (rendered unshadowed)");
        s.effects.shadows = false;
    }
    if (s.effects.scattering) {
        dropped.push_back("scattering: not available on meshes");
        s.effects.scattering = false;
    }
    if (s.filter != ReconstructionFilter::Linear) {
        dropped.push_back("filter " + std::string(filterName(s.filter)) +
                          ": a mesh's field is linear in each tet");
        s.filter = ReconstructionFilter::Linear;
    }
    if (s.smoothing > 0.0) {
        dropped.push_back("smoothing: grids only");
        s.smoothing = 0.0;
    }
    if (s.effects.gradient == GradientKind::Sobel) {
        dropped.push_back("gradient sobel: a tet's gradient is exact and constant");
        s.effects.gradient = GradientKind::Central;
    }
    std::string note;
    if (s.mode == RenderMode::Dvr && s.preintegration == Preintegration::Table2d) {
        s.preintegration = Preintegration::Table3d;
        note = "pre-integration 2d: cell segments differ in length, so the 3D table over lengths is used";
    }
    EffectPlan p =
        planEffects(s, meshBounds(m), meshValueRange(m), "tets whose scalar range the TF maps to zero");
    // The shared planner words the 3D table and gradients for grids; say what a mesh does.
    for (auto& c : p.compiled) {
        if (c == "pre-integration: 3D table over segment lengths")
            c = "pre-integration: 3D table, each cell segment looked up exactly (lengths up to the longest "
                "edge)";
        if (c.rfind("shading:", 0) == 0)
            c += s.effects.smoothNormals ? " (smooth normals: vertex normals interpolated in each tet)"
                                         : " (flat: per-tet gradient)";
    }
    planNanColor(s, meshHasNonFinite(m), p);
    if (s.mode == RenderMode::Dvr && s.preintegration == Preintegration::None)
        p.compiled.push_back("point sampling every render.step along the ray inside the mesh");
    if (!note.empty()) p.compiled.push_back(note);
    p.dropped.insert(p.dropped.end(), dropped.begin(), dropped.end());
    return p;
}

double meshGradientThreshold(const mesh::TetMesh& m) {
    return 1e-6 * std::max(double(m.valueMax) - double(m.valueMin), 1e-30) /
           std::max(m.maxEdgeLength, 1e-300);
}

VolclLightingParams meshLightingParams(const Scene& scene, const mesh::TetMesh& mesh, const Vec3& centre,
                                       double scale) {
    VolclLightingParams p = lightingParams(scene, meshGradientThreshold(mesh) * scale);
    for (unsigned i = 0; i < p.lightCount; ++i)
        if (p.lightPos[i][3] == float(VOLCL_LIGHT_POINT))
            for (int a = 0; a < 3; ++a)
                p.lightPos[i][a] = float((double(p.lightPos[i][a]) - centre[a]) / scale);
    return p;
}

namespace {

using mesh::FaceId;
using mesh::kNoFace;

class MeshTracer {
public:
    MeshTracer(const mesh::TetMesh& m, const TransferFunction& tf, const Scene& s)
        : m_(m), tf_(tf), scene_(unshadowed(s)), cam_(s.camera ? *s.camera : defaultCamera(meshBounds(m))),
          lighting_(scene_, cam_), clipPlanes_(activeClipPlanes(s.effects)), breakpoints_(tf.breakpoints()),
          bvh_(mesh_detail::buildBoundaryBvh(m)) {
        const bool marching = s.mode == RenderMode::Dvr || s.mode == RenderMode::Iso;
        if (marching)
            for (const auto& iso : s.effects.isosurfaces)
                if (iso.rgba[3] > 0.0) isos_.push_back(iso);
        gradMin_ = meshGradientThreshold(m);
        eps_ = 1e-9 * std::max(norm(sub(m.boundsMax, m.boundsMin)), 1e-300);
        window_ = mipWindow(s, meshValueRange(m));
        nanTau_ = nanExtinction(s);
        if (lighting_.lit() && s.effects.smoothNormals) normals_ = vertexNormals(m);
    }

    const Camera& camera() const noexcept { return cam_; }
    bool depthChannel() const noexcept { return !isos_.empty(); }

    ReferencePixel trace(const CameraRay& ray) const {
        Pixel px;
        px.c0 = 0.0;
        px.c1 = std::numeric_limits<double>::infinity();
        if (!clipToPlanes(clipPlanes_, ray, px.c0, px.c1) || !(px.c1 > px.c0)) return emptyReferencePixel();
        const Vec3& o = ray.origin;
        const Vec3& d = ray.direction;
        std::vector<FaceId> recent;
        // The part of the ray inside the mesh is the union of its intervals in the tets. Every walk from an
        // entering boundary face crosses face-adjacent tets up to a boundary face it leaves by: one interval of
        // the union. Walks start at every entering face along the whole line (behind the eye too: a walk that
        // starts there covers an eye inside the mesh), taken in the order of their t, and only the part past
        // `covered`, the end of what earlier walks integrated, counts. Sorted by start, the intervals add up to
        // their union even where tets overlap (folded tets, overlapping components).
        double tEntry = -std::numeric_limits<double>::infinity();
        double covered = px.c0;
        const std::size_t stepLimit = 8 * m_.tets.size() + 1024;
        std::size_t steps = 0;
        while (steps < stepLimit) {
            const auto hit = mesh_detail::firstEntry(m_, bvh_, o, d, tEntry - eps_, recent);
            if (!hit || hit->t > px.c1) break;
            ++steps; // each search finds a face not in `recent`: a bound even if many faces share one t
            if (recent.size() == 4) recent.erase(recent.begin());
            recent.push_back(hit->face);
            tEntry = hit->t;
            std::size_t tet = mesh::faceTet(hit->face);
            unsigned entered = mesh::faceLocal(hit->face);
            double t = hit->t;
            for (; steps < stepLimit; ++steps) {
                double best = std::numeric_limits<double>::infinity(), bestNd = -1.0;
                int exitFace = -1, steepest = -1;
                for (unsigned f = 0; f < 4; ++f) {
                    if (f == entered) continue;
                    const auto pl = mesh_detail::facePlane(m_, mesh::faceId(tet, f));
                    const double nd = dot(pl.normal, d);
                    if (nd > bestNd) {
                        bestNd = nd;
                        steepest = int(f);
                    }
                    if (!(nd > 0.0)) continue;
                    const double tf = dot(pl.normal, sub(pl.vertex, o)) / nd;
                    if (tf < best) {
                        best = tf;
                        exitFace = int(f);
                    }
                }
                if (exitFace < 0) { // no face ahead (a ray in the plane of a flat tet): leave at once
                    exitFace = steepest;
                    best = t;
                }
                const double tExit = std::max(best, t);
                if (tExit > covered) {
                    segment(ray, tet, std::max(t, covered), tExit, px);
                    covered = tExit;
                }
                t = tExit;
                if (px.T < 1e-12 || t > px.c1) return px.result(*this);
                const FaceId nb = m_.neighbors[mesh::faceId(tet, unsigned(exitFace))];
                if (nb == kNoFace) break;
                tet = mesh::faceTet(nb);
                entered = mesh::faceLocal(nb);
            }
        }
        return px.result(*this);
    }

private:
    struct Pixel {
        Vec3 rgb{0, 0, 0};
        double T = 1.0, depth = std::numeric_limits<double>::infinity();
        double mip = -std::numeric_limits<double>::infinity(), xray = 0.0;
        bool inside = false;
        double c0 = 0.0, c1 = 0.0; ///< the clip planes' ray interval
        ReferencePixel result(const MeshTracer& tr) const {
            const double inf = std::numeric_limits<double>::infinity();
            if (tr.scene_.mode == RenderMode::Mip) {
                if (!inside) return emptyReferencePixel();
                const auto c = tr.tf_.colorAt(mip);
                if (tr.scene_.mipColor == MipColor::TfOpacity) {
                    const double a = 1.0 - std::exp(-tr.tf_.extinctionAt(mip));
                    return {c[0] * a, c[1] * a, c[2] * a, a, inf};
                }
                const double g = std::clamp((mip - tr.window_[0]) / tr.window_[1], 0.0, 1.0);
                if (tr.scene_.mipColor == MipColor::Tf) return {c[0] * g, c[1] * g, c[2] * g, g, inf};
                return {g, g, g, g, inf};
            }
            if (tr.scene_.mode == RenderMode::Xray) {
                const double a = -std::expm1(-xray);
                return {a, a, a, a, inf};
            }
            if (tr.scene_.mode == RenderMode::Emission) return {rgb[0], rgb[1], rgb[2], 0.0, inf};
            return {rgb[0], rgb[1], rgb[2], 1.0 - T, depth};
        }
    };

    static Scene unshadowed(Scene s) {
        s.effects.shadows = false;
        s.effects.scattering = false;
        return s;
    }

    /// The part of tet `tet` on [ta, tb] (clipped to the clip planes' interval).
    void segment(const CameraRay& ray, std::size_t tet, double ta, double tb, Pixel& px) const {
        const double a = std::max(ta, px.c0), b = std::min(tb, px.c1);
        if (!(b >= a)) return;
        if (tetHasNonFinite(m_, tet)) {
            // A NaN cell: a constant segment of the NaN colour in dvr (unlit), nothing in the other modes.
            if (scene_.mode != RenderMode::Dvr || !(b > a)) return;
            const double alpha = -std::expm1(-nanTau_ * (b - a));
            for (int c = 0; c < 3; ++c)
                px.rgb[c] += px.T * alpha * scene_.nanColor[c];
            px.T *= 1.0 - alpha;
            return;
        }
        const mesh_detail::TetField field = mesh_detail::tetField(m_, tet);
        const Vec3& o = ray.origin;
        const Vec3& d = ray.direction;
        const double sa = field.at(add(o, scale(d, a))), sb = field.at(add(o, scale(d, b)));
        const double len = b - a;
        switch (scene_.mode) {
        case RenderMode::Mip:
            px.mip = std::max({px.mip, sa, sb});
            px.inside = true;
            return;
        case RenderMode::Xray:
            if (len > 0.0)
                for (const auto& p : preint::segmentPieces(tf_, breakpoints_, sa, sb))
                    px.xray += len * p.h * 0.5 * (p.tauA + p.tauB);
            return;
        case RenderMode::
            Emission: // c and tau linear on a piece: the integral of their product in closed form
            if (len > 0.0)
                for (const auto& p : preint::segmentPieces(tf_, breakpoints_, sa, sb))
                    for (int c = 0; c < 3; ++c)
                        px.rgb[c] += len * p.h *
                                     ((p.cA[c] * p.tauA + p.cB[c] * p.tauB) / 3.0 +
                                      (p.cA[c] * p.tauB + p.cB[c] * p.tauA) / 6.0);
            return;
        default:
            break;
        }
        if (!(len > 0.0)) return;
        // Iso crossings inside the segment, in ray order (sides: s >= value or s < value).
        std::vector<std::pair<double, std::size_t>> cross;
        for (std::size_t i = 0; i < isos_.size(); ++i) {
            const double v = isos_[i].value;
            if ((sa >= v) != (sb >= v)) cross.push_back({std::clamp((v - sa) / (sb - sa), 0.0, 1.0), i});
        }
        std::sort(cross.begin(), cross.end());
        // The gradient shading takes at x: the tet's own, or its interpolated vertex normals.
        std::optional<TetNormalField> smooth;
        if (!normals_.empty()) smooth = tetNormalField(m_, normals_, tet);
        auto gradientAt = [&](const Vec3& x) { return smooth ? smooth->at(x) : field.gradient; };
        const bool dvr = scene_.mode == RenderMode::Dvr;
        double u0 = 0.0;
        auto piece = [&](double u1) {
            if (!dvr || !(u1 > u0)) return;
            const double s0 = sa + (sb - sa) * u0, s1 = sa + (sb - sa) * u1, l = len * (u1 - u0);
            const auto r = preint::integratePieces(preint::segmentPieces(tf_, breakpoints_, s0, s1), l);
            if (!(r[3] > 0.0) && r[0] == 0.0 && r[1] == 0.0 && r[2] == 0.0) return;
            Vec3 c{r[0], r[1], r[2]};
            if (lighting_.lit()) {
                const Vec3 x = add(o, scale(d, a + len * 0.5 * (u0 + u1)));
                const Vec3 S = light(ray, x, {0, 0, 0}, gradientAt(x));
                const Vec3 K = sub(light(ray, x, {1, 1, 1}, gradientAt(x)), S);
                c = add(mul(K, c), scale(S, r[3]));
            }
            px.rgb = add(px.rgb, scale(c, px.T));
            px.T *= 1.0 - r[3];
        };
        for (const auto& [u, i] : cross) {
            piece(u);
            u0 = u;
            const IsoLayer& iso = isos_[i];
            const double t = a + len * u;
            const Vec3 x = add(o, scale(d, t));
            const Vec3 c = light(ray, x, {iso.rgba[0], iso.rgba[1], iso.rgba[2]}, gradientAt(x));
            if (std::isinf(px.depth)) px.depth = t;
            px.rgb = add(px.rgb, scale(c, px.T * iso.rgba[3]));
            px.T *= 1.0 - iso.rgba[3];
        }
        piece(1.0);
    }

    Vec3 light(const CameraRay& ray, const Vec3& x, const Vec3& c, const Vec3& gradient) const {
        return lighting_.light(
            ray, x, c, gradMin_, [&] { return gradient; }, [](const Vec3&, double) { return 1.0; });
    }

    const mesh::TetMesh& m_;
    const TransferFunction& tf_;
    Scene scene_;
    Camera cam_;
    ReferenceLighting lighting_;
    std::vector<ClipPlane> clipPlanes_; ///< the scene's clip planes and its crop box's
    std::vector<double> breakpoints_;
    mesh_detail::BoundaryBvh bvh_;
    std::vector<IsoLayer> isos_;
    std::vector<Vec3> normals_; ///< smooth shading: the vertex normals (empty: flat, per-tet gradients)
    double gradMin_ = 0.0, eps_ = 0.0, nanTau_ = 0.0;
    std::array<double, 2> window_{0.0, 1.0};
};

} // namespace

ImageBuffer meshReferenceRender(const mesh::TetMesh& mesh, const TransferFunction& tf, const Scene& scene,
                                const ReferenceOptions& options) {
    scene.validate();
    tf.validate();
    if (mesh.tets.empty()) throw DataError("mesh has no tetrahedra");
    const MeshTracer tracer(mesh, tf, scene);
    return traceReferenceImage(scene, tracer.camera(), tracer.depthChannel(), options.threads,
                               [&](const CameraRay& ray) { return tracer.trace(ray); });
}

} // namespace volcl
