// Iso-surface tables (Roettger 8.13) and pre-integrated lighting tables (Guthe 1.3.4), both on the host.
#include "core/Error.hpp"
#include "core/runtime/ParallelFor.hpp"
#include "host/image/ImageIo.hpp"
#include "host/tf/TransferFunction.hpp"
#include "preintegration/PreintegrationTable.hpp"
#include "preintegration/Reference.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace volcl {

ImageBuffer isoSurfaceTableImage(const std::vector<IsoSurface>& surfaces, std::array<double, 2> domain,
                                 int size) {
    if (size < 2 || size > 16384) throw UsageError("iso table size must be between 2 and 16384");
    if (!(domain[0] < domain[1])) throw UsageError("iso table domain must satisfy lo < hi");
    std::ostringstream list;
    list << '[';
    for (std::size_t i = 0; i < surfaces.size(); ++i) {
        const IsoSurface& s = surfaces[i];
        if (!std::isfinite(s.value)) throw DataError("iso-value " + std::to_string(i) + " is not finite");
        for (double c : s.rgba)
            if (!(c >= 0.0 && c <= 1.0)) throw DataError("iso-surface colour components must lie in [0, 1]");
        if (s.rgba[0] > s.rgba[3] || s.rgba[1] > s.rgba[3] || s.rgba[2] > s.rgba[3])
            throw DataError("iso-surface colours are associated: r, g, b must not exceed a");
        list << (i ? "," : "") << '[' << s.value << ',' << s.rgba[0] << ',' << s.rgba[1] << ',' << s.rgba[2]
             << ',' << s.rgba[3] << ']';
    }
    list << ']';
    std::vector<IsoSurface> sorted(surfaces);
    std::sort(sorted.begin(), sorted.end(),
              [](const IsoSurface& a, const IsoSurface& b) { return a.value < b.value; });

    ImageBuffer img(size, size, {"R", "G", "B", "A"});
    auto node = [&](int i) { return preint::nodeValue(domain, size, i); };
    for (int jf = 0; jf < size; ++jf) {
        const double sf = node(jf);
        for (int ib = 0; ib < size; ++ib) {
            const double sb = node(ib);
            std::array<double, 4> acc{0, 0, 0, 0};
            auto composite = [&](const IsoSurface& s) {
                if ((sf >= s.value) == (sb >= s.value)) return;
                double t = 1.0 - acc[3];
                for (int c = 0; c < 4; ++c)
                    acc[c] += t * s.rgba[c];
            };
            // Front to back: ascending iso-values when the scalar increases along the segment, else
            // descending.
            if (sb >= sf)
                for (const auto& s : sorted)
                    composite(s);
            else
                for (auto it = sorted.rbegin(); it != sorted.rend(); ++it)
                    composite(*it);
            for (int c = 0; c < 4; ++c)
                img.at(ib, jf, c) = static_cast<float>(acc[c]);
        }
    }
    img.attributes.push_back(
        {"volcl:domain", std::array<float, 2>{static_cast<float>(domain[0]), static_cast<float>(domain[1])}});
    img.attributes.push_back({"volcl:method", std::string("iso")});
    img.attributes.push_back({"volcl:isoValues", list.str()});
    return img;
}

LightingEntry referenceLighting(const TransferFunction& tf, double sFront, double sBack, double length) {
    LightingEntry e;
    auto pieces = preint::segmentPieces(tf, tf.breakpoints(), sFront, sBack);
    auto amb = preint::integratePieces(pieces, length);
    e.ambient = amb;
    e.diffuseBack = {0, 0, 0};
    double weighted = 0.0; // l int w tau E dw
    double depth = 0.0;
    if (length > 0.0) {
        for (const auto& p : pieces) {
            double pa = length * p.h * p.tauA, pb = length * p.h * p.tauB;
            double tA = std::exp(-depth);
            if (tA > 1e-300 && (pa > 0.0 || pb > 0.0)) {
                // Integrand over v in [0, 1]: w(v) * (c(v), 1) * rate(v) * T(v), rate = d depth / dv.
                std::function<std::array<double, 4>(double)> f = [&](double v) -> std::array<double, 4> {
                    double w = p.w0 + p.h * v;
                    double rate = pa + (pb - pa) * v;
                    double t = tA * std::exp(-v * (pa + 0.5 * (pb - pa) * v));
                    double k = w * rate * t;
                    std::array<double, 4> r;
                    for (int c = 0; c < 3; ++c)
                        r[c] = k * (p.cA[c] + (p.cB[c] - p.cA[c]) * v);
                    r[3] = k;
                    return r;
                };
                auto r = preint::gaussKronrod<4>(f, 0.0, 1.0, 1e-15, 1e-12);
                for (int c = 0; c < 3; ++c)
                    e.diffuseBack[c] += r[c];
                weighted += r[3];
            }
            depth += 0.5 * (pa + pb);
        }
    }
    for (int c = 0; c < 3; ++c) {
        e.diffuseBack[c] = std::clamp(e.diffuseBack[c], 0.0, amb[c]);
        e.diffuseFront[c] = amb[c] - e.diffuseBack[c];
    }
    e.omegaStar = amb[3] > 1e-300 ? std::clamp(weighted / amb[3], 0.0, 1.0) : 0.5;
    return e;
}

ImageBuffer lightingTableImage(const TransferFunction& tf, int size, double step, int threads) {
    tf.validate();
    TableSpec spec;
    spec.size = size;
    spec.step = step;
    spec.validate();
    ImageBuffer img(size, size,
                    {"R", "G", "B", "A", "Df.R", "Df.G", "Df.B", "Db.R", "Db.G", "Db.B", "omega"});
    auto node = [&](int i) { return preint::nodeValue(tf.domain, size, i); };
    parallelFor(static_cast<std::size_t>(size) * size, hostThreads(threads), [&](std::size_t pair) {
        int jf = static_cast<int>(pair / size), ib = static_cast<int>(pair % size);
        LightingEntry e = referenceLighting(tf, node(jf), node(ib), step);
        float vals[11] = {float(e.ambient[0]),      float(e.ambient[1]),      float(e.ambient[2]),
                          float(e.ambient[3]),      float(e.diffuseFront[0]), float(e.diffuseFront[1]),
                          float(e.diffuseFront[2]), float(e.diffuseBack[0]),  float(e.diffuseBack[1]),
                          float(e.diffuseBack[2]),  float(e.omegaStar)};
        for (int c = 0; c < 11; ++c)
            img.at(ib, jf, c) = vals[c];
    });
    img.attributes.push_back({"volcl:domain", std::array<float, 2>{static_cast<float>(tf.domain[0]),
                                                                   static_cast<float>(tf.domain[1])}});
    img.attributes.push_back({"volcl:method", std::string("lighting")});
    img.attributes.push_back({"volcl:step", static_cast<float>(step)});
    img.attributes.push_back({"volcl:tf", tf.toJson()});
    return img;
}

} // namespace volcl
