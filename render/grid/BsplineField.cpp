// Cubic B-spline coefficients of a grid (recursive prefilter, mirror margins), evaluation and macrocells.
#include "render/grid/BsplineField.hpp"

#include "core/Error.hpp"
#include "core/Volume.hpp"
#include "core/runtime/ParallelFor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace volcl {
namespace {

/// Whole-sample mirror of index i into [0, n): ..., 2, 1, [0, 1, ..., n-1], n-2, ... (n = 1: always 0).
std::size_t mirror(long i, std::size_t n) {
    if (n == 1) return 0;
    const long period = 2 * (long(n) - 1);
    long m = std::abs(i) % period;
    if (m >= long(n)) m = period - m;
    return std::size_t(m);
}

/// In-place interpolation prefilter of one line (cubic B-spline, pole sqrt(3) - 2, mirror boundary):
/// afterwards the spline through the coefficients passes through the original samples.
void prefilterLine(double* c, std::size_t n) {
    if (n < 2) return;
    const double z = std::sqrt(3.0) - 2.0;
    const double lambda = (1.0 - z) * (1.0 - 1.0 / z); // 6: the gain that makes the filter interpolate
    for (std::size_t k = 0; k < n; ++k)
        c[k] *= lambda;
    // Causal initial value: the mirror-extended sum, truncated where z^k falls below double precision.
    const std::size_t horizon = std::size_t(std::ceil(std::log(1e-17) / std::log(std::abs(z))));
    double sum;
    if (horizon < n) {
        double zn = z;
        sum = c[0];
        for (std::size_t k = 1; k < horizon; ++k) {
            sum += zn * c[k];
            zn *= z;
        }
    } else {
        double zn = z;
        const double iz = 1.0 / z;
        double z2n = std::pow(z, double(n - 1));
        sum = c[0] + z2n * c[n - 1];
        z2n *= z2n * iz;
        for (std::size_t k = 1; k + 1 < n; ++k) {
            sum += (zn + z2n) * c[k];
            zn *= z;
            z2n *= iz;
        }
        sum /= 1.0 - zn * zn;
    }
    c[0] = sum;
    for (std::size_t k = 1; k < n; ++k)
        c[k] += z * c[k - 1];
    c[n - 1] = (z / (z * z - 1.0)) * (z * c[n - 2] + c[n - 1]);
    for (std::size_t k = n - 1; k-- > 0;)
        c[k] = z * (c[k + 1] - c[k]);
}

/// Convolves one line with the normalised Gaussian `kernel` (taps -r..r), mirror boundary.
void gaussianLine(double* c, std::size_t n, const std::vector<double>& kernel, std::vector<double>& scratch) {
    const long r = long(kernel.size() / 2);
    scratch.assign(c, c + n);
    for (std::size_t k = 0; k < n; ++k) {
        double sum = 0.0;
        for (long j = -r; j <= r; ++j)
            sum += kernel[std::size_t(j + r)] * scratch[mirror(long(k) + j, n)];
        c[k] = sum;
    }
}

/// Cubic B-spline weights of the four coefficients around fraction f in [0, 1], and their derivatives.
void weights(double f, double w[4], double d[4]) {
    const double g = 1.0 - f, f2 = f * f;
    w[0] = g * g * g / 6.0;
    w[1] = (3.0 * f2 * f - 6.0 * f2 + 4.0) / 6.0;
    w[2] = (-3.0 * f2 * f + 3.0 * f2 + 3.0 * f + 1.0) / 6.0;
    w[3] = f2 * f / 6.0;
    d[0] = -0.5 * g * g;
    d[1] = 1.5 * f2 - 2.0 * f;
    d[2] = -1.5 * f2 + f + 0.5;
    d[3] = 0.5 * f2;
}

} // namespace

std::size_t bsplineCoefficientBytes(const Volume& volume, std::size_t bytesPerCoefficient) {
    const Dims& d = volume.dims();
    return (d.x + 3) * (d.y + 3) * (d.z + 3) * bytesPerCoefficient;
}

template <class T>
BsplineCoefficients<T> bsplineCoefficients(const Volume& volume, ReconstructionFilter filter,
                                           double smoothing) {
    if (filter == ReconstructionFilter::Linear)
        throw UsageError("bsplineCoefficients: the linear filter has none");
    if (!(smoothing >= 0.0 && smoothing <= kMaxSmoothing))
        throw UsageError("smoothing must be in [0, " + std::to_string(int(kMaxSmoothing)) + "] voxels");
    const Dims& d = volume.dims();
    BsplineCoefficients<T> out;
    out.dims = {d.x, d.y, d.z};
    out.padded = {d.x + 3, d.y + 3, d.z + 3};
    const std::size_t px = out.padded[0], py = out.padded[1], pz = out.padded[2];
    out.c.assign(px * py * pz, T(0));
    // Interior: the voxels at offset (1, 1, 1).
    parallelFor(d.z, 0u, [&](std::size_t k) {
        for (std::size_t j = 0; j < d.y; ++j)
            for (std::size_t i = 0; i < d.x; ++i)
                out.c[out.index(i + 1, j + 1, k + 1)] = T(volume.valueAt(volume.index(i, j, k)));
    });
    // Separable line filters along x, then y, then z, each line in double.
    auto pass = [&](auto&& lineFilter) {
        auto along = [&](std::size_t n, std::size_t stride, std::size_t lines, auto&& lineStart) {
            parallelFor(lines, 0u, [&](std::size_t l) {
                std::vector<double> line(n), scratch;
                const std::size_t s0 = lineStart(l);
                for (std::size_t k = 0; k < n; ++k)
                    line[k] = double(out.c[s0 + k * stride]);
                lineFilter(line.data(), n, scratch);
                for (std::size_t k = 0; k < n; ++k)
                    out.c[s0 + k * stride] = T(line[k]);
            });
        };
        along(d.x, 1, d.y * d.z, [&](std::size_t l) { return out.index(1, 1 + l % d.y, 1 + l / d.y); });
        along(d.y, px, d.x * d.z, [&](std::size_t l) { return out.index(1 + l % d.x, 1, 1 + l / d.x); });
        along(d.z, px * py, d.x * d.y, [&](std::size_t l) { return out.index(1 + l % d.x, 1 + l / d.x, 1); });
    };
    if (smoothing > 0.0) {
        const long r = std::max(1L, long(std::ceil(3.0 * smoothing)));
        std::vector<double> kernel(std::size_t(2 * r + 1));
        double sum = 0.0;
        for (long j = -r; j <= r; ++j)
            sum += kernel[std::size_t(j + r)] = std::exp(-0.5 * double(j * j) / (smoothing * smoothing));
        for (double& k : kernel)
            k /= sum;
        pass([&](double* c, std::size_t n, std::vector<double>& scratch) {
            gaussianLine(c, n, kernel, scratch);
        });
    }
    if (filter == ReconstructionFilter::Cubic)
        pass([](double* c, std::size_t n, std::vector<double>&) { prefilterLine(c, n); });
    // Margins: mirror of the interior (index -1 -> 1, n -> n - 2, n + 1 -> n - 3).
    parallelFor(pz, 0u, [&](std::size_t k) {
        const std::size_t sk = mirror(long(k) - 1, d.z) + 1;
        for (std::size_t j = 0; j < py; ++j) {
            const std::size_t sj = mirror(long(j) - 1, d.y) + 1;
            for (std::size_t i = 0; i < px; ++i) {
                const std::size_t si = mirror(long(i) - 1, d.x) + 1;
                if (si != i || sj != j || sk != k) out.c[out.index(i, j, k)] = out.c[out.index(si, sj, sk)];
            }
        }
    });
    return out;
}

template BsplineCoefficients<float> bsplineCoefficients<float>(const Volume&, ReconstructionFilter, double);
template BsplineCoefficients<double> bsplineCoefficients<double>(const Volume&, ReconstructionFilter, double);

Volume smoothedVolume(const Volume& volume, double smoothing) {
    const BsplineCoefficients<float> c =
        bsplineCoefficients<float>(volume, ReconstructionFilter::Bspline, smoothing);
    Volume out(volume.dims(), ScalarType::Float32);
    out.origin = volume.origin;
    out.spacing = volume.spacing;
    auto v = out.values<float>();
    const Dims& d = volume.dims();
    for (std::size_t k = 0; k < d.z; ++k)
        for (std::size_t j = 0; j < d.y; ++j)
            for (std::size_t i = 0; i < d.x; ++i)
                v[out.index(i, j, k)] = c.c[c.index(i + 1, j + 1, k + 1)];
    return out;
}

double bsplineValue(const BsplineCoefficients<double>& field, const Vec3& p, Vec3* gradient) {
    std::size_t i0[3];
    double w[3][4], dw[3][4];
    for (int a = 0; a < 3; ++a) {
        const std::size_t n = field.dims[std::size_t(a)];
        const double x = std::clamp(p[std::size_t(a)], 0.0, double(n - 1));
        const std::size_t i = std::min(std::size_t(std::floor(x)), n >= 2 ? n - 2 : 0);
        i0[a] = i; // padded index of coefficient i - 1
        weights(x - double(i), w[a], dw[a]);
    }
    double value = 0.0, gx = 0.0, gy = 0.0, gz = 0.0;
    for (int c = 0; c < 4; ++c)
        for (int b = 0; b < 4; ++b) {
            const double* row = &field.c[field.index(i0[0], i0[1] + std::size_t(b), i0[2] + std::size_t(c))];
            double sw = 0.0, sd = 0.0;
            for (int a = 0; a < 4; ++a) {
                sw += w[0][a] * row[a];
                sd += dw[0][a] * row[a];
            }
            value += w[1][b] * w[2][c] * sw;
            gx += w[1][b] * w[2][c] * sd;
            gy += dw[1][b] * w[2][c] * sw;
            gz += w[1][b] * dw[2][c] * sw;
        }
    if (gradient) {
        *gradient = {gx, gy, gz};
        for (int a = 0; a < 3; ++a)
            if (field.dims[std::size_t(a)] < 2) (*gradient)[std::size_t(a)] = 0.0;
    }
    return value;
}

grid_detail::MacrocellGrid bsplineMacrocells(const BsplineCoefficients<float>& field, unsigned edge) {
    grid_detail::MacrocellGrid g;
    g.edge = edge;
    auto cells = [edge](std::size_t n) {
        return unsigned(std::max<std::size_t>(1, (n - 1 + edge - 1) / edge));
    };
    g.nx = cells(field.dims[0]);
    g.ny = cells(field.dims[1]);
    g.nz = cells(field.dims[2]);
    const std::size_t count = std::size_t(g.nx) * g.ny * g.nz;
    g.min.assign(count, std::numeric_limits<float>::infinity());
    g.max.assign(count, -std::numeric_limits<float>::infinity());
    // A point in voxels [c*edge, (c+1)*edge] reads coefficients c*edge - 1 .. (c+1)*edge + 2, which are the
    // padded indices c*edge .. (c+1)*edge + 3.
    auto span = [&](unsigned c, std::size_t axis, std::size_t& lo, std::size_t& hi) {
        lo = std::size_t(c) * edge;
        hi = std::min(lo + edge + 3, field.padded[axis] - 1);
    };
    parallelFor(g.nz, 0u, [&](std::size_t cz) {
        std::size_t z0, z1;
        span(unsigned(cz), 2, z0, z1);
        for (unsigned cy = 0; cy < g.ny; ++cy) {
            std::size_t y0, y1;
            span(cy, 1, y0, y1);
            for (unsigned cx = 0; cx < g.nx; ++cx) {
                std::size_t x0, x1;
                span(cx, 0, x0, x1);
                float lo = std::numeric_limits<float>::infinity(), hi = -lo;
                for (std::size_t k = z0; k <= z1; ++k)
                    for (std::size_t j = y0; j <= y1; ++j) {
                        const float* row = &field.c[field.index(0, j, k)];
                        for (std::size_t i = x0; i <= x1; ++i) {
                            lo = std::min(lo, row[i]);
                            hi = std::max(hi, row[i]);
                        }
                    }
                const std::size_t c = (cz * g.ny + cy) * g.nx + cx;
                g.min[c] = lo;
                g.max[c] = hi;
            }
        }
    });
    return g;
}

} // namespace volcl
