// `volcl bench mesh-codec`: .vcm size and speed per quantisation (the --bits knob: error against size and
// time) and lossless, against gzip -9 and xz -9 of the same mesh as a .vtu, measured in the same run.
#include "apps/bench/BenchCommand.hpp"
#include "apps/bench/BenchOutput.hpp"
#include "apps/bench/BenchPaths.hpp"
#include "apps/bench/CodecPeers.hpp"
#include "core/Error.hpp"
#include "core/runtime/Timing.hpp"
#include "meshcodec/MeshCodec.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <sstream>

#include <unistd.h>

namespace volcl::cli {

namespace {

namespace fs = std::filesystem;

struct MeshCodecBenchArgs {
    std::string data = defaultSharedDataDir(), csv, json;
    std::vector<std::string> meshes = {"unstructured/xsmall_turb.vtu", "unstructured/bluntfinxyz.bin"};
    std::vector<int> bits = {8, 10, 12, 14, 16, 20};
    int runs = 5;
};

struct Row {
    std::string mesh, config;
    std::size_t tets = 0, points = 0, bytes = 0, connectivityBytes = 0, geometryBytes = 0;
    double encodeMs = 0, decodeMs = 0, maxPositionError = 0, maxScalarError = 0, boxDiagonal = 0;
};

/// The largest decoded position error (over the axes) and scalar error, through the renumbering.
void measureErrors(const mesh::TetMesh& m, const meshcodec::EncodedMesh& e, const meshcodec::DecodedMesh& d,
                   Row& row) {
    for (std::size_t i = 0; i < m.pointCount(); ++i) {
        const std::uint32_t j = e.newIndex[i];
        for (int a = 0; a < 3; ++a)
            row.maxPositionError = std::max(row.maxPositionError, std::abs(d.points[j][a] - m.points[i][a]));
        row.maxScalarError =
            std::max(row.maxScalarError, std::abs(double(d.scalars[j]) - double(m.scalars[i])));
    }
}

void benchMeshCodec(const MeshCodecBenchArgs& a, GlobalOptions& global) {
    std::vector<Row> rows;
    nlohmann::json peers = nlohmann::json::array();
    const fs::path tmp = fs::temp_directory_path() / ("volcl-bench-mesh-codec-" + std::to_string(::getpid()));
    fs::create_directories(tmp);
    for (const std::string& name : a.meshes) {
        const fs::path path = fs::path(a.data) / name;
        if (!fs::exists(path)) {
            std::cerr << "volcl bench mesh-codec: " << path.string() << " is absent, skipped\n";
            continue;
        }
        const mesh::TetMesh m = meshcodec::readAnyMesh(path);
        const std::string label = path.filename().string();
        // The peers: the same mesh (after the reader's repairs) as a raw-binary .vtu, through gzip -9 and xz -9.
        const fs::path vtu = tmp / "mesh.vtu";
        mesh::writeVtu(m, vtu);
        double gzipMs = 0, xzMs = 0;
        const std::size_t vtuBytes = fs::file_size(vtu);
        const std::size_t gzipBytes = compressedFileSize("gzip -9", vtu, gzipMs);
        const std::size_t xzBytes = compressedFileSize("xz -9 -T1", vtu, xzMs);
        fs::remove(vtu);
        peers.push_back({{"mesh", label},
                         {"tets", m.tetCount()},
                         {"points", m.pointCount()},
                         {"vtu_bytes", vtuBytes},
                         {"gzip9_bytes", gzipBytes},
                         {"gzip9_ms", gzipMs},
                         {"xz9_bytes", xzBytes},
                         {"xz9_ms", xzMs}});
        std::vector<meshcodec::VcmOptions> configs;
        for (const int b : a.bits)
            configs.push_back({b, false});
        configs.push_back({16, true});
        // Interleaved: every configuration once per round, the medians over rounds.
        std::vector<std::vector<double>> enc(configs.size()), dec(configs.size());
        std::vector<Row> meshRows(configs.size());
        for (int run = 0; run < a.runs; ++run)
            for (std::size_t c = 0; c < configs.size(); ++c) {
                Stopwatch se;
                const meshcodec::EncodedMesh e = meshcodec::encodeMesh(m, configs[c]);
                enc[c].push_back(se.milliseconds());
                Stopwatch sd;
                const meshcodec::DecodedMesh d = meshcodec::decodeMesh(e.bytes, label);
                dec[c].push_back(sd.milliseconds());
                if (run > 0) continue;
                Row& r = meshRows[c];
                r.mesh = label;
                r.config = configs[c].lossless ? "lossless" : std::to_string(configs[c].bits) + " bits";
                r.tets = m.tetCount();
                r.points = m.pointCount();
                r.bytes = e.bytes.size();
                r.connectivityBytes = e.header.sectionSize[meshcodec::ConnectivityRans] +
                                      e.header.sectionSize[meshcodec::ConnectivityRaw];
                r.geometryBytes = e.header.sectionSize[meshcodec::GeometryRans] +
                                  e.header.sectionSize[meshcodec::GeometryRaw];
                double diag = 0;
                for (int k = 0; k < 3; ++k)
                    diag += (m.boundsMax[k] - m.boundsMin[k]) * (m.boundsMax[k] - m.boundsMin[k]);
                r.boxDiagonal = std::sqrt(diag);
                measureErrors(m, e, d, r);
            }
        for (std::size_t c = 0; c < configs.size(); ++c) {
            meshRows[c].encodeMs = median(enc[c]);
            meshRows[c].decodeMs = median(dec[c]);
            rows.push_back(meshRows[c]);
        }
        if (!global.quiet)
            std::cerr << "volcl bench mesh-codec: " << label << ": .vtu " << vtuBytes << " bytes, gzip -9 "
                      << gzipBytes << ", xz -9 " << xzBytes << '\n';
    }
    fs::remove_all(tmp);
    const std::string load = loadAverage();
    std::ostringstream csv;
    csv << "# volcl bench mesh-codec, load average " << load << ", medians of " << a.runs
        << " interleaved runs (one thread)\n";
    csv << "mesh,config,tets,points,bytes,connectivity_bits_per_tet,geometry_bits_per_vertex,bits_per_tet,"
           "max_position_error_rel_diagonal,max_scalar_error,encode_ms,decode_ms,encode_mtets_s,decode_mtets_"
           "s,"
           "ratio_vs_vtu,ratio_vs_gzip9,ratio_vs_xz9\n";
    nlohmann::json j;
    j["load_average"] = load;
    j["runs"] = a.runs;
    j["peers"] = peers;
    j["rows"] = nlohmann::json::array();
    for (const Row& r : rows) {
        const auto peer =
            std::find_if(peers.begin(), peers.end(), [&](const auto& p) { return p["mesh"] == r.mesh; });
        const double vtuBytes = (*peer)["vtu_bytes"], gzipBytes = (*peer)["gzip9_bytes"],
                     xzBytes = (*peer)["xz9_bytes"];
        const double cbt = 8.0 * double(r.connectivityBytes) / double(r.tets),
                     gbv = 8.0 * double(r.geometryBytes) / double(r.points),
                     bt = 8.0 * double(r.bytes) / double(r.tets);
        const double relErr = r.maxPositionError / r.boxDiagonal;
        csv << r.mesh << ',' << r.config << ',' << r.tets << ',' << r.points << ',' << r.bytes << ',' << cbt
            << ',' << gbv << ',' << bt << ',' << relErr << ',' << r.maxScalarError << ',' << r.encodeMs << ','
            << r.decodeMs << ',' << double(r.tets) / r.encodeMs / 1e3 << ','
            << double(r.tets) / r.decodeMs / 1e3 << ',' << vtuBytes / double(r.bytes) << ','
            << gzipBytes / double(r.bytes) << ',' << xzBytes / double(r.bytes) << '\n';
        j["rows"].push_back({{"mesh", r.mesh},
                             {"config", r.config},
                             {"tets", r.tets},
                             {"points", r.points},
                             {"bytes", r.bytes},
                             {"connectivity_bits_per_tet", cbt},
                             {"geometry_bits_per_vertex", gbv},
                             {"bits_per_tet", bt},
                             {"max_position_error_rel_diagonal", relErr},
                             {"max_scalar_error", r.maxScalarError},
                             {"encode_ms", r.encodeMs},
                             {"decode_ms", r.decodeMs},
                             {"ratio_vs_vtu", vtuBytes / double(r.bytes)},
                             {"ratio_vs_gzip9", gzipBytes / double(r.bytes)},
                             {"ratio_vs_xz9", xzBytes / double(r.bytes)}});
    }
    writeOutput(a.csv, csv.str());
    if (!a.json.empty()) writeOutput(a.json, j.dump(2) + "\n");
}

} // namespace

void addMeshCodecBench(CLI::App& bench, GlobalOptions& global) {
    auto* b = bench.add_subcommand(
        "mesh-codec", ".vcm mesh compression: bits per tet and vertex, error and speed per --bits, lossless, "
                      "against gzip -9 and xz -9 of the .vtu");
    auto a = std::make_shared<MeshCodecBenchArgs>();
    b->add_option("--data", a->data, "Shared data directory")->capture_default_str();
    b->add_option("--mesh", a->meshes, "Meshes relative to --data (repeatable)")->capture_default_str();
    b->add_option("--bits", a->bits, "Quantisation bits to measure (repeatable)")->capture_default_str();
    b->add_option("--runs", a->runs, "Timed runs per configuration (median of interleaved runs)")
        ->capture_default_str();
    b->add_option("--csv", a->csv, "CSV output file (default: stdout)");
    b->add_option("--json", a->json, "JSON output file");
    b->callback([a, &global] {
        if (a->runs < 1) throw UsageError("--runs must be at least 1");
        for (const int bits : a->bits)
            if (bits < meshcodec::kMinBits || bits > meshcodec::kMaxBits)
                throw UsageError("--bits " + std::to_string(bits) + " is out of range 1-30");
        benchMeshCodec(*a, global);
    });
}

} // namespace volcl::cli
