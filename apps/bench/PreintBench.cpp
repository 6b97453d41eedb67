// `volcl bench preint`: every pre-integration method's time and error against the reference, and VTK's
// builders as peers.
#include "apps/bench/BenchCommand.hpp"

#include "apps/bench/BenchPaths.hpp"
#include "apps/cli/CliParsing.hpp"
#include "core/AtomicFile.hpp"
#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "core/runtime/Timing.hpp"
#include "host/tf/TransferFunction.hpp"
#include "preintegration/PreintegrationTable.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include <unistd.h>

namespace volcl::cli {

namespace {

// The documented example transfer function (docs/contract.md): the default for `bench preint`.
constexpr const char* kDefaultBenchTf = R"({"domain": [0, 255],
  "color": [[0, 0.0, 0.0, 0.0], [128, 1.0, 0.6, 0.2], [255, 1.0, 1.0, 1.0]],
  "extinction": [[0, 0.0], [60, 0.0], [80, 0.8], [255, 0.05]]})";

struct BenchRow {
    std::string method, dims, precision, knob;
    int size = 0, lengths = 1;
    double knobValue = 0.0, timeMs = 0.0, deviceMs = 0.0, maxErr = 0.0, rmsErr = 0.0;
    std::size_t entries = 0;
    int runs = 0;
};

nlohmann::json rowJson(const BenchRow& r) {
    return {{"method", r.method},
            {"dims", r.dims},
            {"size", r.size},
            {"lengths", r.lengths},
            {"precision", r.precision},
            {"knob", r.knob},
            {"knob_value", r.knobValue},
            {"time_ms", r.timeMs},
            {"device_ms", r.deviceMs},
            {"max_err", r.maxErr},
            {"rms_err", r.rmsErr},
            {"entries", r.entries},
            {"runs", r.runs}};
}

void printRow(const BenchRow& r) {
    std::cout << std::left << std::setw(18) << r.method << std::setw(4) << r.dims << std::right
              << std::setw(6) << r.size << std::setw(5) << r.lengths << ' ' << std::setw(6) << r.precision
              << ' ' << std::setw(10)
              << (r.knob.empty() ? "-"
                                 : r.knob + "=" +
                                       [&] {
                                           std::ostringstream s;
                                           s << r.knobValue;
                                           return s.str();
                                       }())
              << std::setw(11) << std::fixed << std::setprecision(2) << r.timeMs << std::setw(11)
              << r.deviceMs << std::setw(12) << std::scientific << std::setprecision(2) << r.maxErr
              << std::setw(11) << r.rmsErr << std::defaultfloat << std::setprecision(6) << std::setw(10)
              << r.entries << '\n';
}

// Full reference tables are cached per shape: several rows compare against the same one.
struct ReferenceCache {
    std::map<std::string, std::vector<double>> tables;
    const std::vector<double>& get(const TransferFunction& tf, const TableSpec& spec) {
        std::ostringstream key;
        key << spec.size << 'x' << spec.lengths << 'x' << spec.maxLength << 'x' << spec.step << 'x'
            << static_cast<int>(spec.axis);
        auto it = tables.find(key.str());
        if (it != tables.end()) return it->second;
        GeneratorOptions o;
        o.method = PreintMethod::Reference;
        auto t = generatePreintegrationTable(tf, spec, o, nullptr);
        return tables[key.str()] = std::vector<double>(t.rgba.begin(), t.rgba.end());
    }
};

struct BenchArgs {
    std::string tfPath, csvPath, jsonPath, vtkScript = peerScriptDir() + "/vtk_preint_peer.py";
    int runs = 5;
    bool quick = false, vtk = false, headline = false;
    double step = 1.0, maxLength = 4.0;
    std::size_t samples = 200000;
};

// Runs the VTK peer script on the 3D shape and returns its JSON report (times, table file paths).
nlohmann::json runVtkPeer(const BenchArgs& a, const TransferFunction& tf, int n, int lengths,
                          double maxLength, const std::filesystem::path& work) {
    std::filesystem::create_directories(work);
    auto tfPath = work / "tf.json", report = work / "vtk.json";
    {
        std::ofstream out(tfPath);
        out << tf.toJson();
        if (!out) throw IoError("cannot write " + tfPath.string());
    }
    std::string cmd = "/usr/bin/python3 " + shellQuote(a.vtkScript) + " --tf " + shellQuote(tfPath.string()) +
                      " --size " + std::to_string(n) + " --lengths " + std::to_string(lengths) +
                      " --max-length " + std::to_string(maxLength) + " --runs " + std::to_string(a.runs) +
                      " --out-dir " + shellQuote(work.string()) + " --report " + shellQuote(report.string());
    std::cerr << "volcl bench preint: running the VTK peer: " << cmd << '\n';
    int rc = std::system(cmd.c_str());
    if (rc != 0)
        throw Error("VTK peer script failed (exit " + std::to_string(rc) +
                    "); is python3-vtk9 installed (scripts/apt-packages.txt)?");
    std::ifstream in(report);
    if (!in) throw IoError("VTK peer wrote no report at " + report.string());
    return nlohmann::json::parse(in);
}

// VTK's table: float32 [d][s_b][s_f][4] with d * maxLength' / (L - 1); its slice d is our slice d - 1 when
// maxLength' = maxLength (L - 1) / L (the script does that). Slice 0 (zero length) is skipped.
TableError vtkError(const std::filesystem::path& raw, const std::vector<double>& ref, int n, int lengths) {
    std::vector<std::byte> bytes = readFileBytes(raw);
    std::size_t expect = static_cast<std::size_t>(lengths) * n * n * 4 * sizeof(float);
    if (bytes.size() != expect)
        throw IoError(raw.string() + ": VTK table has " + std::to_string(bytes.size()) + " bytes, expected " +
                      std::to_string(expect));
    const float* v = reinterpret_cast<const float*>(bytes.data());
    TableError e;
    double s2 = 0.0;
    const std::size_t nn = static_cast<std::size_t>(n) * n;
    for (int d = 1; d < lengths; ++d)
        for (int sb = 0; sb < n; ++sb)
            for (int sf = 0; sf < n; ++sf) {
                const float* x = v + ((static_cast<std::size_t>(d) * n + sb) * n + sf) * 4;
                const double* r =
                    &ref[((static_cast<std::size_t>(d - 1) * nn) + static_cast<std::size_t>(sf) * n + sb) *
                         4];
                for (int c = 0; c < 4; ++c) {
                    double diff = std::isfinite(x[c]) ? std::abs(double(x[c]) - r[c]) : HUGE_VAL;
                    s2 += diff * diff;
                    if (!(diff <= e.maxAbs)) {
                        e.maxAbs = diff;
                        e.worstK = d - 1;
                        e.worstFront = sf;
                        e.worstBack = sb;
                        e.worstChannel = c;
                    }
                }
                ++e.entries;
            }
    e.rms = std::sqrt(s2 / (4.0 * static_cast<double>(std::max<std::size_t>(e.entries, 1))));
    return e;
}

// One run of the benchmark: the table generator, the reference tables and the rows measured so far.
struct PreintBench {
    const BenchArgs& args;
    const TransferFunction& tf;
    PreintegrationGenerator gen;
    ReferenceCache refs;
    std::vector<BenchRow> rows;

    PreintBench(const BenchArgs& a, const TransferFunction& t, ComputeContext& cc)
        : args(a), tf(t), gen(&cc) {}

    // Times one table (median of --runs; the reference once) and measures its error against the reference
    // (every entry when `fullCompare`, else --samples of them); prints and keeps the row.
    BenchRow measure(const TableSpec& spec, GeneratorOptions o, const std::string& knob, double knobValue,
                     bool fullCompare) {
        BenchRow r;
        r.method = std::string(methodName(o.method));
        r.dims = spec.axis == LengthAxis::Fixed ? "2D" : "3D";
        r.size = spec.size;
        r.lengths = spec.axis == LengthAxis::Fixed ? 1 : spec.lengths;
        r.precision = o.precision == Precision::Double ? "double" : "float";
        r.knob = knob;
        r.knobValue = knobValue;
        PreintegrationTable t;
        std::vector<double> device;
        int runs = o.method == PreintMethod::Reference ? 1 : args.runs;
        r.timeMs = medianMilliseconds(runs, [&] {
            gen.generate(tf, spec, o, t);
            device.push_back(t.deviceMilliseconds);
        });
        r.runs = runs;
        r.deviceMs = median(device);
        TableError e =
            fullCompare ? compareTables(t, refs.get(tf, spec)) : compareWithReference(t, tf, args.samples);
        r.maxErr = e.maxAbs;
        r.rmsErr = e.rms;
        r.entries = e.entries;
        printRow(r);
        rows.push_back(r);
        return r;
    }
};

// Methods x sizes x (2D, 3D) x precision (none with --headline), then the reference's own cost for scale.
// 3D tables keep at most 2^22 entries: L = min(256, 2^22 / N^2).
void benchMethodsAndSizes(PreintBench& bench, bool fp64) {
    const BenchArgs& a = bench.args;
    const std::vector<PreintMethod> methods{PreintMethod::Exact, PreintMethod::Incremental,
                                            PreintMethod::IntegralFunction, PreintMethod::Roettger2d,
                                            PreintMethod::Polynomial};
    std::vector<int> sizes2d =
        a.quick ? std::vector<int>{64, 256} : std::vector<int>{64, 128, 256, 512, 1024};
    std::vector<int> sizes3d =
        a.quick ? std::vector<int>{64, 128} : std::vector<int>{64, 128, 256, 512, 1024};
    std::vector<Precision> precisions{Precision::Float};
    if (fp64) precisions.push_back(Precision::Double);

    if (a.headline) precisions.clear(); // --headline: only the knob rows at their defaults, and VTK
    for (Precision p : precisions)
        for (PreintMethod m : methods) {
            for (int n : sizes2d) {
                TableSpec s;
                s.size = n;
                s.step = a.step;
                GeneratorOptions o;
                o.method = m;
                o.precision = p;
                bench.measure(s, o, "", 0.0, false);
            }
            for (int n : sizes3d) {
                TableSpec s;
                s.size = n;
                s.axis = LengthAxis::Linear;
                s.lengths = std::max(4, std::min(256, (1 << 22) / (n * n)));
                s.maxLength = a.maxLength;
                GeneratorOptions o;
                o.method = m;
                o.precision = p;
                bench.measure(s, o, "", 0.0, false);
            }
        }
    // The oracle's own cost, for scale.
    for (int n : a.headline ? std::vector<int>{} : std::vector<int>{64, 256}) {
        TableSpec s;
        s.size = n;
        s.step = a.step;
        GeneratorOptions o;
        o.method = PreintMethod::Reference;
        bench.measure(s, o, "", 0.0, false);
    }
}

// Accuracy knobs as error versus time on `spec`, every entry compared with the reference: exact's sub-piece
// depth and the polynomial degree (only depth 1 with --headline).
void benchKnobs(PreintBench& bench, const TableSpec& spec) {
    const BenchArgs& a = bench.args;
    for (double d :
         a.headline ? std::vector<double>{1.0} : std::vector<double>{0.125, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0}) {
        GeneratorOptions o;
        o.maxSubstepDepth = d;
        bench.measure(spec, o, "depth", d, true);
    }
    for (int deg : a.headline ? std::vector<int>{} : std::vector<int>{1, 2, 3, 4}) {
        GeneratorOptions o;
        o.method = PreintMethod::Polynomial;
        o.polynomialDegree = deg;
        bench.measure(spec, o, "degree", deg, true);
    }
}

// The knobs on the 2D 256^2 table and on `vtkShape` (VTK's 128x128x256), then the other methods on
// `vtkShape`, every entry compared with the reference.
void benchKnobsAndVtkShape(PreintBench& bench, const TableSpec& vtkShape) {
    TableSpec s2;
    s2.size = 256;
    s2.step = bench.args.step;
    benchKnobs(bench, s2);
    benchKnobs(bench, vtkShape);
    for (PreintMethod m :
         {PreintMethod::Incremental, PreintMethod::IntegralFunction, PreintMethod::Roettger2d}) {
        GeneratorOptions o;
        o.method = m;
        bench.measure(vtkShape, o, "", 0.0, true);
    }
}

// --vtk: VTK's incremental and direct builders on `s3` as rows, and side by side with our exact table.
// Returns the peer's report with the errors added.
nlohmann::json benchVtk(PreintBench& bench, const TableSpec& s3) {
    const BenchArgs& a = bench.args;
    auto work = std::filesystem::temp_directory_path() / ("volcl-preint-vtk-" + std::to_string(::getpid()));
    nlohmann::json vtk = runVtkPeer(a, bench.tf, s3.size, s3.lengths, s3.maxLength, work);
    const auto& ref = bench.refs.get(bench.tf, s3);
    for (const char* mode : {"incremental", "direct"}) {
        TableError e = vtkError(vtk[mode]["table"].get<std::string>(), ref, s3.size, s3.lengths);
        vtk[mode]["max_err"] = e.maxAbs;
        vtk[mode]["rms_err"] = e.rms;
        vtk[mode]["entries"] = e.entries;
        BenchRow r;
        r.method = std::string("vtk-") + mode;
        r.dims = "3D";
        r.size = s3.size;
        r.lengths = s3.lengths;
        r.precision = "float";
        r.timeMs = vtk[mode]["time_ms"].get<double>();
        r.maxErr = e.maxAbs;
        r.rmsErr = e.rms;
        r.entries = e.entries;
        r.runs = vtk["runs"].get<int>();
        printRow(r);
        bench.rows.push_back(r);
    }
    std::filesystem::remove_all(work);
    // The same run, side by side: our exact table on VTK's shape against VTK's incremental builder.
    const BenchRow* ours = nullptr;
    for (const auto& r : bench.rows)
        if (r.method == "exact" && r.dims == "3D" && r.size == 128 && r.lengths == 256 && r.knob == "depth" &&
            r.knobValue == 1.0)
            ours = &r;
    if (ours)
        std::cout << "side by side (128x128x256, same run): volcl exact " << ours->timeMs << " ms (max err "
                  << ours->maxErr << "), VTK incremental " << vtk["incremental"]["time_ms"].get<double>()
                  << " ms (max err " << vtk["incremental"]["max_err"].get<double>() << "), VTK direct "
                  << vtk["direct"]["time_ms"].get<double>() << " ms (max err "
                  << vtk["direct"]["max_err"].get<double>() << "): volcl is "
                  << vtk["incremental"]["time_ms"].get<double>() / ours->timeMs << "x VTK incremental\n";
    return vtk;
}

// --csv and --json: the rows (JSON also the setup, the copy-kernel ceiling and the VTK report).
void writePreintTables(const BenchArgs& a, const ComputeContext& cc, const TransferFunction& tf,
                       const std::vector<BenchRow>& rows, const nlohmann::json& vtk, double copyGBs) {
    if (!a.csvPath.empty()) {
        AtomicFile out(a.csvPath);
        std::ostringstream csv;
        csv << "method,dims,size,lengths,precision,knob,knob_value,time_ms,device_ms,max_err,rms_err,entries,"
               "runs\n";
        for (const auto& r : rows)
            csv << r.method << ',' << r.dims << ',' << r.size << ',' << r.lengths << ',' << r.precision << ','
                << r.knob << ',' << r.knobValue << ',' << r.timeMs << ',' << r.deviceMs << ',' << r.maxErr
                << ',' << r.rmsErr << ',' << r.entries << ',' << r.runs << '\n';
        out.write(csv.str());
        out.commit();
    }
    if (!a.jsonPath.empty()) {
        nlohmann::json j;
        j["device"] = cc.device().name;
        j["tf"] = nlohmann::json::parse(tf.toJson());
        j["step"] = a.step;
        j["max_length"] = a.maxLength;
        j["runs"] = a.runs;
        j["copy_kernel_GBs"] = copyGBs;
        j["rows"] = nlohmann::json::array();
        for (const auto& r : rows)
            j["rows"].push_back(rowJson(r));
        if (!vtk.is_null()) j["vtk"] = vtk;
        AtomicFile out(a.jsonPath);
        out.write(j.dump(1));
        out.commit();
    }
}

void runBench(const BenchArgs& a, GlobalOptions& global) {
    TransferFunction tf =
        a.tfPath.empty() ? TransferFunction::fromJson(kDefaultBenchTf) : TransferFunction::fromFile(a.tfPath);
    tf.validate();
    if (a.runs < 1) throw UsageError("--runs must be at least 1");
    ComputeContext cc(global.device);
    std::cerr << "volcl bench preint: device " << cc.device().name << ", " << a.runs
              << " timed runs per row (median, after one warm-up run that also builds the kernels)\n";
    PreintBench bench(a, tf, cc);
    std::cout << "method            dim  size    L  prec  knob          time_ms  device_ms     max_err    "
                 "rms_err   entries\n";
    benchMethodsAndSizes(bench, cc.device().fp64);
    // VTK's shape: 128x128x256.
    TableSpec s3;
    s3.size = 128;
    s3.axis = LengthAxis::Linear;
    s3.lengths = 256;
    s3.maxLength = a.maxLength;
    benchKnobsAndVtkShape(bench, s3);
    nlohmann::json vtk;
    if (a.vtk) vtk = benchVtk(bench, s3);
    double copyGBs = copyKernelBandwidthGBs(cc, std::size_t(128) * 128 * 256 * 16, 5);
    writePreintTables(a, cc, tf, bench.rows, vtk, copyGBs);
    std::cerr << "volcl bench preint: copy-kernel ceiling on a 128x128x256 float4 buffer: " << copyGBs
              << " GB/s\n";
}

} // namespace

void addPreintBench(CLI::App& bench, GlobalOptions& global) {
    auto* b = bench.add_subcommand("preint",
                                   "Pre-integration: every method's time and error against the reference");
    auto ba = std::make_shared<BenchArgs>();
    b->add_option("--tf", ba->tfPath, "Transfer function (default: the example of docs/contract.md)");
    b->add_option("--runs", ba->runs, "Timed runs per row (median)")->capture_default_str();
    b->add_flag("--quick", ba->quick, "Fewer sizes (for development)");
    b->add_flag("--headline", ba->headline,
                "Only exact on 2D 256^2 and 3D 128x128x256 (every entry checked), incremental, and --vtk");
    b->add_option("--step", ba->step, "2D segment length")->capture_default_str();
    b->add_option("--max-length", ba->maxLength, "3D largest length")->capture_default_str();
    b->add_option("--samples", ba->samples, "Entries compared with the reference per row (sweep rows)")
        ->capture_default_str();
    b->add_option("--csv", ba->csvPath, "Write the rows as CSV");
    b->add_option("--json", ba->jsonPath, "Write the rows (and the VTK comparison) as JSON");
    b->add_flag("--vtk", ba->vtk,
                "Also time VTK's vtkUnstructuredGridPreIntegration on 128x128x256 (python3-vtk9)");
    b->add_option("--vtk-script", ba->vtkScript, "Path of bench/vtk_preint_peer.py")->capture_default_str();
    b->callback([ba, &global] { runBench(*ba, global); });
}

} // namespace volcl::cli
