// Keys-cubic translation of volumes and Lucas-Kanade estimation of a global sub-voxel translation.
#include "wavelet/predict/GlobalShift.hpp"

#include "core/Error.hpp"
#include "core/runtime/ParallelFor.hpp"
#include "wavelet/BrickVoxels.hpp"

#include <algorithm>
#include <cmath>
#include <memory>

namespace volcl {

namespace {

// Keys cubic convolution weights for the four samples around a position with fraction f in [0, 1).
std::array<double, 4> keysWeights(double f) {
    auto k = [](double t) {
        t = std::abs(t);
        if (t < 1) return 1.5 * t * t * t - 2.5 * t * t + 1;
        if (t < 2) return -0.5 * t * t * t + 2.5 * t * t - 4 * t + 2;
        return 0.0;
    };
    return {k(1 + f), k(f), k(1 - f), k(2 - f)};
}

// Every voxel type converts to float exactly (8/16-bit integers, float32).
std::vector<double> asDoubles(const Volume& v) {
    const std::vector<float> f = v.toFloat();
    return {f.begin(), f.end()};
}

void shiftAll(std::vector<double>& v, Dims d, std::array<double, 3> s, unsigned threads) {
    for (int a = 0; a < 3; ++a)
        keysShiftAxis(v, d, a, s[std::size_t(a)], threads);
}

// Solves the symmetric 3x3 system a x = b by Cramer's rule; false when it is (nearly) singular.
bool solve3(const double a[3][3], const double b[3], double x[3]) {
    auto det = [](const double m[3][3]) {
        return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
               m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    };
    const double d = det(a);
    const double scale = a[0][0] * a[1][1] * a[2][2];
    if (!(std::abs(d) > 1e-12 * std::abs(scale)) || !std::isfinite(d)) return false;
    for (int c = 0; c < 3; ++c) {
        double m[3][3];
        for (int r = 0; r < 3; ++r)
            for (int k = 0; k < 3; ++k)
                m[r][k] = k == c ? b[r] : a[r][k];
        x[c] = det(m) / d;
    }
    return true;
}

// The four Keys taps of a shift: out(i) = sum over t of w[t] in(clamp(i + base - 1 + t)).
struct KeysTaps {
    std::array<double, 4> w;
    long base;
};

KeysTaps keysTaps(double shift) {
    const double start = -shift;
    const double fl = std::floor(start);
    return {keysWeights(start - fl), static_cast<long>(fl)};
}

// One line of n samples shifted from `in` to `out` (distinct). Every output is 0 + w0 a0 + w1 a1 + w2 a2 +
// w3 a3 in that order, on the clamped edges and in the interior alike; the interior (every tap inside the
// line) needs no clamp and vectorises.
void shiftLine(const double* in, double* out, std::size_t n, const KeysTaps& k) {
    const long len = long(n);
    const long lo = std::clamp<long>(1 - k.base, 0, len), hi = std::clamp<long>(len - 2 - k.base, lo, len);
    auto clamped = [&](long i) {
        double acc = 0;
        for (int t = 0; t < 4; ++t)
            acc += k.w[std::size_t(t)] * in[std::clamp<long>(i + k.base - 1 + t, 0, len - 1)];
        out[i] = acc;
    };
    for (long i = 0; i < lo; ++i)
        clamped(i);
    const double w0 = k.w[0], w1 = k.w[1], w2 = k.w[2], w3 = k.w[3];
    const long b = k.base - 1;
    for (long i = lo; i < hi; ++i) {
        double acc = 0;
        acc += w0 * in[i + b];
        acc += w1 * in[i + b + 1];
        acc += w2 * in[i + b + 2];
        acc += w3 * in[i + b + 3];
        out[i] = acc;
    }
    for (long i = hi; i < len; ++i)
        clamped(i);
}

// Rows of x: out[x] = 0 + w0 src0[x] + w1 src1[x] + w2 src2[x] + w3 src3[x] (the y and z passes).
template <class Out>
void blendRows(Out* out, const double* const src[4], const std::array<double, 4>& w, std::size_t n) {
    const double w0 = w[0], w1 = w[1], w2 = w[2], w3 = w[3];
    const double *s0 = src[0], *s1 = src[1], *s2 = src[2], *s3 = src[3];
    for (std::size_t x = 0; x < n; ++x) {
        double acc = 0;
        acc += w0 * s0[x];
        acc += w1 * s1[x];
        acc += w2 * s2[x];
        acc += w3 * s3[x];
        out[x] = static_cast<Out>(acc);
    }
}

// Row r (y + z * dims.y) of `v` as doubles: every voxel type converts exactly.
void rowAsDoubles(const Volume& v, std::size_t r, double* out) {
    const std::size_t n = v.dims().x, first = r * n;
    codec::visitTyped(v, [&](auto values) {
        for (std::size_t i = 0; i < n; ++i)
            out[i] = static_cast<double>(values[first + i]);
    });
}

// The y pass in place: each z slice is copied aside (small), then its rows are blended from the copy.
void shiftRowsAlongY(double* v, Dims d, double shift, unsigned threads) {
    if (shift == 0) return;
    const KeysTaps k = keysTaps(shift);
    const std::size_t rowLen = d.x, plane = d.x * d.y;
    parallelFor(d.z, threads, [&](std::size_t z) {
        thread_local std::vector<double> slice;
        double* p = v + z * plane;
        slice.assign(p, p + plane);
        for (std::size_t y = 0; y < d.y; ++y) {
            const double* src[4];
            for (int t = 0; t < 4; ++t)
                src[t] = slice.data() +
                         std::size_t(std::clamp<long>(long(y) + k.base - 1 + t, 0, long(d.y) - 1)) * rowLen;
            blendRows(p + y * rowLen, src, k.w, rowLen);
        }
    });
}

// The rows of z slices blended from `src` into `out` (which may be float): out(z) = sum w[t] src(z + taps).
template <class Out>
void shiftRowsAlongZ(const double* src, Out* out, Dims d, double shift, unsigned threads) {
    const KeysTaps k = keysTaps(shift);
    const std::size_t rowLen = d.x, plane = d.x * d.y;
    parallelFor(d.z * d.y, threads, [&](std::size_t r) {
        const std::size_t z = r / d.y, y = r % d.y;
        const double* taps[4];
        for (int t = 0; t < 4; ++t)
            taps[t] = src +
                      std::size_t(std::clamp<long>(long(z) + k.base - 1 + t, 0, long(d.z) - 1)) * plane +
                      y * rowLen;
        blendRows(out + r * rowLen, taps, k.w, rowLen);
    });
}

} // namespace

void keysShiftAxis(std::vector<double>& v, Dims d, int axis, double shift, unsigned threads) {
    if (shift == 0) return;
    if (axis == 0) {
        const KeysTaps k = keysTaps(shift);
        parallelFor(d.y * d.z, threads, [&](std::size_t r) {
            thread_local std::vector<double> line;
            double* row = v.data() + r * d.x;
            line.assign(row, row + d.x);
            shiftLine(line.data(), row, d.x, k);
        });
    } else if (axis == 1) {
        shiftRowsAlongY(v.data(), d, shift, threads);
    } else {
        const std::vector<double> copy = v;
        shiftRowsAlongZ(copy.data(), v.data(), d, shift, threads);
    }
}

// The same arithmetic as converting to doubles and calling keysShiftAxis for x, y and z, then rounding to
// float, with two passes fewer: the x pass reads the voxels as they are stored, and the z pass writes the
// rounded floats, so neither a converted copy nor the z pass's in-place copy is made.
Volume cubicShifted(const Volume& v, std::array<double, 3> shift, unsigned threads) {
    const Dims d = v.dims();
    const std::size_t rowLen = d.x;
    // Every element is written by the x pass: no zero fill.
    const std::unique_ptr<double[]> buffer(new double[d.count()]);
    double* const s = buffer.get();
    const KeysTaps kx = keysTaps(shift[0]);
    parallelFor(d.y * d.z, threads, [&](std::size_t r) {
        double* row = s + r * rowLen;
        if (shift[0] == 0) return rowAsDoubles(v, r, row);
        thread_local std::vector<double> line;
        line.resize(rowLen);
        rowAsDoubles(v, r, line.data());
        shiftLine(line.data(), row, rowLen, kx);
    });
    shiftRowsAlongY(s, d, shift[1], threads);
    Volume out(d, ScalarType::Float32);
    float* o = out.values<float>().data();
    if (shift[2] == 0)
        parallelFor(d.z * d.y, threads, [&](std::size_t r) {
            for (std::size_t x = 0; x < rowLen; ++x)
                o[r * rowLen + x] = static_cast<float>(s[r * rowLen + x]);
        });
    else
        shiftRowsAlongZ(s, o, d, shift[2], threads);
    out.spacing = v.spacing;
    out.origin = v.origin;
    return out;
}

GlobalShift estimateGlobalShift(const Volume& current, const Volume& reference, std::array<double, 3> start,
                                unsigned threads) {
    if (current.dims() != reference.dims()) throw DataError("global shift: the frames differ in dims");
    const Dims d = current.dims();
    const std::vector<double> cur = asDoubles(current), ref = asDoubles(reference);
    std::array<double, 3> s = start;
    // Gradients use central differences two voxels away from the faces, where clamp-to-edge samples would
    // bias the fit; a volume thinner than that along an axis keeps that component.
    const bool live[3] = {d.x > 6, d.y > 6, d.z > 6};
    for (int iter = 0; iter < 5; ++iter) {
        std::vector<double> w = ref;
        shiftAll(w, d, s, threads);
        const std::size_t sx = 1, sy = d.x, sz = d.x * d.y;
        // Per z slice sums of g g^T and g e, added in slice order (the same result for any thread count).
        struct Sums {
            double a[3][3] = {}, b[3] = {};
        };
        std::vector<Sums> slices(d.z);
        parallelFor(d.z, threads, [&](std::size_t z) {
            if (live[2] && (z < 2 || z + 2 >= d.z)) return;
            Sums& m = slices[z];
            for (std::size_t y = live[1] ? 2 : 0; y < (live[1] ? d.y - 2 : d.y); ++y)
                for (std::size_t x = live[0] ? 2 : 0; x < (live[0] ? d.x - 2 : d.x); ++x) {
                    const std::size_t i = x + y * sy + z * sz;
                    const double g[3] = {live[0] ? 0.5 * (w[i + sx] - w[i - sx]) : 0.0,
                                         live[1] ? 0.5 * (w[i + sy] - w[i - sy]) : 0.0,
                                         live[2] ? 0.5 * (w[i + sz] - w[i - sz]) : 0.0};
                    const double e = cur[i] - w[i];
                    for (int r = 0; r < 3; ++r) {
                        m.b[r] += g[r] * e;
                        for (int c = 0; c < 3; ++c)
                            m.a[r][c] += g[r] * g[c];
                    }
                }
        });
        Sums t;
        for (const Sums& m : slices)
            for (int r = 0; r < 3; ++r) {
                t.b[r] += m.b[r];
                for (int c = 0; c < 3; ++c)
                    t.a[r][c] += m.a[r][c];
            }
        // A component without gradient (a flat or thin axis) is held: its row and column become identity.
        for (int r = 0; r < 3; ++r)
            if (!live[r] || !(t.a[r][r] > 0)) {
                for (int c = 0; c < 3; ++c)
                    t.a[r][c] = t.a[c][r] = 0;
                t.a[r][r] = 1;
                t.b[r] = 0;
            }
        double rhs[3] = {-t.b[0], -t.b[1], -t.b[2]}, delta[3];
        if (!solve3(t.a, rhs, delta)) break;
        double largest = 0;
        for (int c = 0; c < 3; ++c) {
            const double step = std::clamp(delta[c], -1.0, 1.0); // the linear model holds within a voxel
            s[std::size_t(c)] += step;
            largest = std::max(largest, std::abs(step));
        }
        if (largest < 0.25 / kGlobalShiftUnits) break;
    }
    auto stored = [](double v) {
        const double m = double(kGlobalShiftMaxVoxels * kGlobalShiftUnits);
        return static_cast<std::int16_t>(std::clamp(std::round(v * kGlobalShiftUnits), -m, m));
    };
    if (!std::isfinite(s[0]) || !std::isfinite(s[1]) || !std::isfinite(s[2])) return {};
    return {stored(s[0]), stored(s[1]), stored(s[2])};
}

} // namespace volcl
