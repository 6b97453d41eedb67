// vtkVczReader: .vcz -> vtkImageData for ParaView, one brick-aligned z slab per piece, shared planes by MPI.
#include "vtkVczReader.h"

#include "plugins/paraview/VczPieces.hpp"

#include "core/AtomicFile.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "wavelet/Codec.hpp"

#include "vtkDataArray.h"
#include "vtkImageData.h"
#include "vtkInformation.h"
#include "vtkInformationVector.h"
#include "vtkMultiProcessController.h"
#include "vtkObjectFactory.h"
#include "vtkPointData.h"
#include "vtkSmartPointer.h"
#include "vtkStreamingDemandDrivenPipeline.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <vector>

vtkStandardNewMacro(vtkVczReader);

namespace {

using namespace volcl;

int vtkTypeOf(ScalarType t) {
    switch (t) {
    case ScalarType::UInt8:
        return VTK_UNSIGNED_CHAR;
    case ScalarType::UInt16:
        return VTK_UNSIGNED_SHORT;
    case ScalarType::Int16:
        return VTK_SHORT;
    case ScalarType::Float32:
        return VTK_FLOAT;
    case ScalarType::Float64:
        return VTK_DOUBLE;
    }
    return VTK_FLOAT;
}

double millisecondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Message tag of the shared plane sent from a slab to the slab below it.
constexpr int kPlaneTag = 0x7c2a;

// Figures of one rank's RequestData, gathered as doubles (AllGather of a fixed-size record).
struct RankFigures {
    double piece = 0, frame = 0, level = 0, zlo = 0, zhi = 0, bricks = 0, fileBricks = 0, readMs = 0,
           decodeMs = 0, exchangeMs = 0, ok = 1;
    static constexpr int kCount = 11;
    void to(double* d) const { std::copy_n(&piece, kCount, d); }
    static RankFigures from(const double* d) {
        RankFigures f;
        std::copy_n(d, kCount, &f.piece);
        return f;
    }
};

} // namespace

struct vtkVczReader::Internals {
    std::string path;
    std::filesystem::file_time_type stamp{};
    std::optional<VczReader> reader;
    double readMs = 0;
    std::optional<ComputeContext> cc; // made on the first decode (RequestInformation needs no device)
    std::vector<double> times;        // one per frame, increasing

    // (Re)reads the file when the name or the file's modification time changed.
    void open(const std::string& name) {
        if (name.empty()) throw std::runtime_error("vtkVczReader: no FileName set");
        std::error_code ec;
        const auto t = std::filesystem::last_write_time(name, ec);
        if (reader && name == path && !ec && t == stamp) return;
        reader.reset();
        const auto t0 = std::chrono::steady_clock::now();
        reader.emplace(readFileBytes(name), name); // validates header and index; names the file on error
        readMs = millisecondsSince(t0);
        path = name;
        stamp = t;
        const VczHeader& h = reader->header();
        // Frame times as stored when they increase, else the frame numbers (ParaView needs increasing times).
        times.clear();
        bool increasing = true;
        for (std::size_t f = 0; f < h.frames.size(); ++f) {
            times.push_back(h.frames[f].time);
            if (f > 0 && !(times[f] > times[f - 1])) increasing = false;
        }
        if (!increasing)
            for (std::size_t f = 0; f < times.size(); ++f)
                times[f] = double(f);
    }

    std::size_t frameAt(double t) const {
        std::size_t f = 0;
        while (f + 1 < times.size() && times[f + 1] <= t + 1e-9 * std::max(1.0, std::abs(t)))
            ++f;
        return f;
    }
};

vtkVczReader::vtkVczReader() : Impl(std::make_unique<Internals>()) {
    this->SetNumberOfInputPorts(0);
}

vtkVczReader::~vtkVczReader() = default;

int vtkVczReader::CanReadFile(const char* name) {
    std::ifstream in(name ? name : "", std::ios::binary);
    std::array<char, kVczMagic.size()> magic{};
    return in.read(magic.data(), std::streamsize(magic.size())) &&
           std::memcmp(magic.data(), kVczMagic.data(), magic.size()) == 0;
}

int vtkVczReader::RequestInformation(vtkInformation*, vtkInformationVector**,
                                     vtkInformationVector* outputVector) {
    vtkInformation* outInfo = outputVector->GetInformationObject(0);
    try {
        this->Impl->open(this->FileName);
        const VczHeader& h = this->Impl->reader->header();
        // The decoder's limit: raw-bit files subsample to any level, wavelet files to their encoded levels.
        this->LevelRange[1] = h.transform == TransformKind::RawBits ? 16 : h.levels;
        if (this->Level > this->LevelRange[1])
            throw std::runtime_error(this->FileName + ": level " + std::to_string(this->Level) +
                                     " is beyond the file's " + std::to_string(this->LevelRange[1]) +
                                     " levels");
        const Dims d = pieces::levelDims(h, this->Level);
        const double f = double(1 << this->Level);
        int whole[6] = {0, int(d.x) - 1, 0, int(d.y) - 1, 0, int(d.z) - 1};
        double spacing[3] = {h.spacing[0] * f, h.spacing[1] * f, h.spacing[2] * f};
        outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole, 6);
        outInfo->Set(vtkDataObject::SPACING(), spacing, 3);
        outInfo->Set(vtkDataObject::ORIGIN(), h.origin[0], h.origin[1], h.origin[2]);
        vtkDataObject::SetPointDataActiveScalarInfo(outInfo, vtkTypeOf(h.voxelType()), 1);
        // Pieces, not sub-extents: the reader picks brick-aligned slabs itself.
        outInfo->Set(vtkAlgorithm::CAN_HANDLE_PIECE_REQUEST(), 1);
        outInfo->Remove(vtkStreamingDemandDrivenPipeline::TIME_STEPS());
        outInfo->Remove(vtkStreamingDemandDrivenPipeline::TIME_RANGE());
        const auto& t = this->Impl->times;
        if (t.size() > 1) {
            outInfo->Set(vtkStreamingDemandDrivenPipeline::TIME_STEPS(), t.data(), int(t.size()));
            double range[2] = {t.front(), t.back()};
            outInfo->Set(vtkStreamingDemandDrivenPipeline::TIME_RANGE(), range, 2);
        }
    } catch (const std::exception& e) {
        vtkErrorMacro(<< e.what());
        return 0;
    }
    return 1;
}

int vtkVczReader::RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector) {
    vtkInformation* outInfo = outputVector->GetInformationObject(0);
    vtkImageData* out = vtkImageData::GetData(outInfo);
    if (!out || !this->Impl->reader) {
        vtkErrorMacro(<< (this->FileName.empty() ? "no FileName set" : this->FileName + ": not opened"));
        return 0;
    }
    const VczHeader& h = this->Impl->reader->header();
    const int piece = outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER())
                          ? outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER())
                          : 0;
    const int pieceCount =
        outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES())
            ? std::max(1, outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES()))
            : 1;
    const std::size_t frame =
        outInfo->Has(vtkStreamingDemandDrivenPipeline::UPDATE_TIME_STEP())
            ? this->Impl->frameAt(outInfo->Get(vtkStreamingDemandDrivenPipeline::UPDATE_TIME_STEP()))
            : 0;
    // Under MPI with one piece per rank, the shared plane comes from the rank above; otherwise (serial,
    // or pieces not matching ranks) this piece decodes it itself.
    vtkMultiProcessController* mpc = vtkMultiProcessController::GetGlobalController();
    const bool exchange = pieceCount > 1 && mpc && mpc->GetNumberOfProcesses() == pieceCount &&
                          mpc->GetLocalProcessId() == piece;

    auto extentOf = [&](int p) { return pieces::pieceExtent(h, this->Level, p, pieceCount); };
    const pieces::Extent own = extentOf(piece);
    int below = -1, above = -1; // nearest non-empty pieces under and over this one
    for (int p = piece - 1; p >= 0 && below < 0; --p)
        if (!extentOf(p).empty()) below = p;
    for (int p = piece + 1; p < pieceCount && above < 0; ++p)
        if (!extentOf(p).empty()) above = p;
    const bool sharesAbove = !own.empty() && above >= 0;

    const Dims d = pieces::levelDims(h, this->Level);
    const std::size_t planeSamples = d.x * d.y, sampleBytes = scalarSize(h.type);
    const std::size_t planes = own.empty() ? 0 : own.hi.z - own.lo.z + (sharesAbove ? 1 : 0);
    vtkSmartPointer<vtkDataArray> values;
    values.TakeReference(vtkDataArray::CreateDataArray(vtkTypeOf(h.voxelType())));
    values->SetName("values");
    values->SetNumberOfTuples(vtkIdType(planeSamples * planes));
    auto* dst = static_cast<std::byte*>(values->GetVoidPointer(0));

    RankFigures mine;
    mine.piece = piece;
    mine.frame = double(frame);
    mine.level = double(this->Level);
    mine.zlo = double(own.lo.z);
    mine.zhi = double(own.hi.z);
    mine.fileBricks = double(h.brickCount());
    mine.readMs = this->Impl->readMs;
    std::string failure;
    auto t0 = std::chrono::steady_clock::now();
    if (!own.empty()) {
        try {
            pieces::Extent decoded = own;
            if (sharesAbove && !exchange) decoded.hi.z += 1;
            if (!this->Impl->cc) { // the OpenCL context is made once, outside the decode time
                this->Impl->cc.emplace();
                t0 = std::chrono::steady_clock::now();
            }
            CodecProfile profile;
            DecodeOptions o;
            o.region = pieces::regionOf(h, this->Level, decoded);
            o.level = this->Level;
            o.frame = frame;
            o.profile = &profile;
            // Ranks of a parallel run share the node's cores: one decoding thread each.
            if (pieceCount > 1) o.threads = 1;
            const Volume v = this->Impl->reader->decode(*this->Impl->cc, o);
            std::memcpy(dst, v.bytes().data(), v.byteSize());
            mine.bricks = double(profile.bricks);
        } catch (const std::exception& e) {
            failure = e.what();
            mine.ok = 0;
        }
    }
    mine.decodeMs = millisecondsSince(t0);

    const auto t1 = std::chrono::steady_clock::now();
    if (exchange) {
        // Chain: each slab sends its first plane (and whether it decoded) to the slab below, then takes the
        // plane from the slab above. The lowest slab only receives, so the blocking sends cannot deadlock.
        std::vector<char> msg(planeSamples * sampleBytes + 1);
        if (!own.empty() && below >= 0) {
            if (mine.ok) std::memcpy(msg.data(), dst, planeSamples * sampleBytes);
            msg.back() = char(mine.ok ? 1 : 0);
            mpc->Send(msg.data(), vtkIdType(msg.size()), below, kPlaneTag);
        }
        if (sharesAbove) {
            mpc->Receive(msg.data(), vtkIdType(msg.size()), above, kPlaneTag);
            std::memcpy(dst + (planes - 1) * planeSamples * sampleBytes, msg.data(),
                        planeSamples * sampleBytes);
            if (!msg.back() && mine.ok) {
                failure = this->FileName + ": the rank above failed to decode its slab";
                mine.ok = 0;
            }
        }
    }
    mine.exchangeMs = millisecondsSince(t1);

    std::vector<RankFigures> all{mine};
    if (exchange) {
        std::vector<double> send(RankFigures::kCount), recv(std::size_t(pieceCount) * RankFigures::kCount);
        mine.to(send.data());
        mpc->AllGather(send.data(), recv.data(), RankFigures::kCount);
        all.clear();
        for (int r = 0; r < pieceCount; ++r)
            all.push_back(RankFigures::from(recv.data() + r * RankFigures::kCount));
    }
    std::ostringstream report;
    report << '[';
    for (std::size_t r = 0; r < all.size(); ++r)
        report << (r ? "," : "") << "{\"piece\":" << all[r].piece << ",\"frame\":" << all[r].frame
               << ",\"level\":" << all[r].level << ",\"z\":[" << all[r].zlo << ',' << all[r].zhi
               << "],\"bricks\":" << all[r].bricks << ",\"file_bricks\":" << all[r].fileBricks
               << ",\"read_ms\":" << all[r].readMs << ",\"decode_ms\":" << all[r].decodeMs
               << ",\"exchange_ms\":" << all[r].exchangeMs << ",\"ok\":" << (all[r].ok ? "true" : "false")
               << '}';
    report << ']';
    this->DecodeReport = report.str();
    this->DecodedBricks = int(mine.bricks);

    const bool allOk = std::all_of(all.begin(), all.end(), [](const RankFigures& f) { return f.ok != 0; });
    if (!allOk) {
        out->Initialize();
        if (!failure.empty())
            vtkErrorMacro(<< failure);
        else
            vtkErrorMacro(<< this->FileName << ": another rank failed to decode its slab");
        return 0;
    }
    const double f = double(1 << this->Level);
    out->SetSpacing(h.spacing[0] * f, h.spacing[1] * f, h.spacing[2] * f);
    out->SetOrigin(h.origin[0], h.origin[1], h.origin[2]);
    if (own.empty())
        out->SetExtent(0, -1, 0, -1, 0, -1);
    else
        out->SetExtent(0, int(d.x) - 1, 0, int(d.y) - 1, int(own.lo.z), int(own.lo.z + planes) - 1);
    out->GetPointData()->SetScalars(values);
    if (this->Impl->times.size() > 1)
        out->GetInformation()->Set(vtkDataObject::DATA_TIME_STEP(), this->Impl->times[frame]);
    return 1;
}

void vtkVczReader::PrintSelf(ostream& os, vtkIndent indent) {
    this->Superclass::PrintSelf(os, indent);
    os << indent << "FileName: " << this->FileName << "\n"
       << indent << "Level: " << this->Level << "\n"
       << indent << "DecodedBricks: " << this->DecodedBricks << "\n";
}
