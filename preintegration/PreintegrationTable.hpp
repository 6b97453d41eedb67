// Pre-integration tables (docs/contract.md): table model, generators for every method, EXR layout.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace volcl {

class ComputeContext;
class TransferFunction;
struct ImageBuffer;

/// How a table's entries are computed. `Reference` runs on the host in double precision; the others are
/// OpenCL kernels (see docs/preintegration.md for accuracy and speed of each).
enum class PreintMethod {
    Reference,   ///< exact piecewise integration, adaptive Gauss-Kronrod, double (the accuracy oracle)
    Exact,       ///< float kernel, breakpoint-aware Gauss-Legendre sub-pieces, agrees with Reference to 1e-4
    Incremental, ///< Weiler/VTK length recursion from the shortest length (3D linear axis only)
    IntegralFunction, ///< Engel et al.: integral functions, no self-attenuation inside the segment
    Roettger2d,       ///< Roettger 8.5: one 2D table at the mean length, scaled linearly in length
    Polynomial,       ///< Roettger 9.1: exact alpha, chromaticity polynomial in length (degree n)
};

/// Length axis of a table: one fixed step (2D), or L lengths (3D).
enum class LengthAxis {
    Fixed,       ///< 2D table for `step`
    Linear,      ///< l_k = (k + 1) * maxLength / L
    Exponential, ///< Guthe: l'_k = (k + 1) / L * (1 - 2^-maxLength), l_k = -log2(1 - l'_k)
};

enum class Precision { Float, Double };

/// Entries (nodes^2 x lengths) a table may have: 2^24, 256 MiB of float RGBA; each entry integrates the TF's
/// pieces, so this bounds the generator's work as well as its memory (a 4096^2 2D table, 1024^2 x 16 3D).
inline constexpr std::size_t kMaxTableEntries = std::size_t(1) << 24;

/// Shape of a table. Example: `TableSpec s; s.size = 128; s.axis = LengthAxis::Linear; s.lengths = 256;
/// s.maxLength = 4.0;`
struct TableSpec {
    int size = 256; ///< N nodes over the TF domain, both ends included (N >= 2)
    LengthAxis axis = LengthAxis::Fixed;
    double step = 1.0;      ///< 2D: segment length
    int lengths = 0;        ///< 3D: L
    double maxLength = 0.0; ///< 3D: largest length
    /// Segment length of every slice, ascending (one value for 2D). Throws UsageError on an invalid spec.
    std::vector<double> lengthValues() const;
    void validate() const;
};

/// Knobs of the generators; the defaults meet the 1e-4 accuracy target.
struct GeneratorOptions {
    PreintMethod method = PreintMethod::Exact;
    Precision precision = Precision::Float;
    double maxSubstepDepth =
        1.0;                  ///< Exact: optical depth per Gauss-Legendre sub-piece (smaller = more accurate)
    int polynomialDegree = 2; ///< Polynomial: degree n (1..6)
    int threads = 0;          ///< Reference: host threads (0 = hardware concurrency)
};

/// A table in memory: RGBA floats, entry (k, front i, back j) at ((k * N + i) * N + j) * 4 (the EXR layout:
/// x = back index, y = k * N + front index). Colours are associated; alpha = 1 - transmittance.
/// Example:
/// ```
/// auto tf = volcl::TransferFunction::fromFile("tf.json");
/// volcl::ComputeContext cc;
/// volcl::TableSpec spec; spec.size = 256; spec.step = 0.5;
/// volcl::PreintegrationTable t = volcl::generatePreintegrationTable(tf, spec, {}, &cc);
/// auto rgba = t.entry(0, 10, 200);  // segment from node 10 to node 200, length 0.5
/// t.writeExr("table.exr");
/// ```
class PreintegrationTable {
public:
    TableSpec spec;
    std::array<double, 2> domain{0.0, 1.0};
    PreintMethod method = PreintMethod::Exact;
    std::string tfJson;      ///< canonical JSON of the TF the table was built from
    std::vector<float> rgba; ///< 4 * N * N * L floats
    double deviceMilliseconds =
        0.0; ///< kernel time of the last generation (profiling events; 0 for Reference)

    int size() const noexcept { return spec.size; }
    int sliceCount() const noexcept { return static_cast<int>(lengthValues.size()); }
    std::vector<double> lengthValues;
    std::array<float, 4> entry(int k, int front, int back) const;
    double node(int i) const; ///< s_i = lo + i (hi - lo) / (N - 1)

    /// EXR image with channels R, G, B, A and the volcl:* header attributes.
    ImageBuffer toImage() const;
    /// Inverse of toImage(); throws IoError/DataError when the attributes or the shape do not describe a
    /// table.
    static PreintegrationTable fromImage(const ImageBuffer& image,
                                         const std::filesystem::path& nameForErrors = {});
    void writeExr(const std::filesystem::path& path, bool halfFloat = false) const;
    static PreintegrationTable readExr(const std::filesystem::path& path);
};

/// Builds tables repeatedly (e.g. on every TF edit) reusing device buffers and the output's storage, so
/// steady-state rebuilds pay neither allocation nor page faults. Example:
/// ```
/// volcl::PreintegrationGenerator gen(&cc);
/// volcl::PreintegrationTable table;
/// gen.generate(tf, spec, {}, table);   // table.rgba now holds the new entries
/// ```
class PreintegrationGenerator {
public:
    explicit PreintegrationGenerator(ComputeContext* cc);
    ~PreintegrationGenerator();
    PreintegrationGenerator(const PreintegrationGenerator&) = delete;
    PreintegrationGenerator& operator=(const PreintegrationGenerator&) = delete;
    void generate(const TransferFunction& tf, const TableSpec& spec, const GeneratorOptions& options,
                  PreintegrationTable& out);

private:
    struct Buffers;
    ComputeContext* cc_;
    std::unique_ptr<Buffers> buffers_;
};

/// Builds a table. `cc` may be null only for PreintMethod::Reference. Throws UsageError for an invalid spec
/// or method/spec combination, DataError for an invalid transfer function.
PreintegrationTable generatePreintegrationTable(const TransferFunction& tf, const TableSpec& spec,
                                                const GeneratorOptions& options, ComputeContext* cc);

/// The reference value of one segment in double: {r, g, b, alpha}.
std::array<double, 4> referenceSegment(const TransferFunction& tf, double sFront, double sBack,
                                       double length);

/// Error of a table against the reference: every entry, or `samples` deterministic random entries when the
/// table has more than that many (0 = all).
struct TableError {
    double maxAbs = 0.0, rms = 0.0;
    std::size_t entries = 0;
    int worstK = 0, worstFront = 0, worstBack = 0, worstChannel = 0;
};
TableError compareWithReference(const PreintegrationTable& table, const TransferFunction& tf,
                                std::size_t samples = 0, int threads = 0);
/// Error between two tables of the same shape (max/RMS over all channels).
TableError compareTables(const PreintegrationTable& table, const std::vector<double>& referenceRgba);

std::string_view methodName(PreintMethod m);
PreintMethod parseMethod(std::string_view name); ///< throws UsageError listing the valid names
std::string_view lengthAxisName(LengthAxis a);

/// Iso-surface table (Roettger 8.13, Heaviside limit): entry (s_f, s_b) is the front-to-back composite of the
/// surfaces whose iso-value the segment crosses, independent of the segment length. A surface at v is crossed
/// when exactly one of s_f, s_b is >= v (v in (min, max]), so a ray passing through a node at v counts it
/// once. Colours are associated RGBA (rgb <= a).
struct IsoSurface {
    double value = 0.0;
    std::array<double, 4> rgba{1.0, 1.0, 1.0, 1.0};
};
/// N x N RGBA image (layout of a 2D table) with attributes volcl:domain, volcl:method = "iso" and
/// volcl:isoValues (JSON list of [value, r, g, b, a]).
ImageBuffer isoSurfaceTableImage(const std::vector<IsoSurface>& surfaces, std::array<double, 2> domain,
                                 int size);

/// Pre-integrated lighting terms (Guthe 1.3.4) for one length, in double on the host:
/// ambient = the plain segment colour (same as the table), diffuseFront = l int (1-w) c tau E dw,
/// diffuseBack = l int w c tau E dw, omegaStar = int w tau E / int tau E (specular centre of mass in the
/// segment, 0.5 where nothing is emitted). Channel layout of the image: see lightingTableImage().
struct LightingEntry {
    std::array<double, 4> ambient; ///< rgb + alpha
    std::array<double, 3> diffuseFront, diffuseBack;
    double omegaStar = 0.5;
};
LightingEntry referenceLighting(const TransferFunction& tf, double sFront, double sBack, double length);
/// N x N lighting table for one step as an EXR image with channels R,G,B,A (ambient), Df.R/G/B, Db.R/G/B and
/// omega (attributes as a 2D table, method "lighting").
ImageBuffer lightingTableImage(const TransferFunction& tf, int size, double step, int threads = 0);

} // namespace volcl
