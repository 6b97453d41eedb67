// Fuzz target for .vcz files through the public reader: header and index parsing, then decoding whole,
// a region, a coarser level and single bricks (both entropy coders, every transform, per the seeds).
#include "core/Error.hpp"
#include "core/runtime/ClRuntime.hpp"
#include "fuzz/FuzzSupport.hpp"
#include "wavelet/BrickVoxels.hpp"
#include "wavelet/Codec.hpp"
#include "wavelet/container/VczFormat.hpp"

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string_view>

namespace {

volcl::ComputeContext& computeContext() {
    static const std::unique_ptr<volcl::ComputeContext> cc = std::make_unique<volcl::ComputeContext>();
    return *cc;
}

// The decodes each input goes through: whole, a region, a coarser level and single bricks of the last frame.
void decodeEveryWay(volcl::ComputeContext& cc, const volcl::VczReader& reader) {
    using namespace volcl;
    const VczHeader& h = reader.header();
    DecodeOptions whole;
    whole.threads = 1;
    (void)reader.decode(cc, whole);
    if (h.dims.x > 1 && h.dims.y > 1 && h.dims.z > 1) {
        DecodeOptions region = whole;
        region.region = Region{{h.dims.x / 2, 0, h.dims.z / 2}, {h.dims.x, h.dims.y / 2 + 1, h.dims.z}};
        (void)reader.decode(cc, region);
    }
    if (h.levels > 0) {
        DecodeOptions coarse = whole;
        coarse.level = 1;
        (void)reader.decode(cc, coarse);
    }
    const std::size_t bricks = h.brickCount();
    for (std::size_t b = 0; b < std::min<std::size_t>(bricks, 2); ++b)
        (void)reader.decodeBrick(cc, h.frames.size() - 1, bricks - 1 - b, 0);
}

// A small voxel pattern, shifted from frame to frame so that a series has motion to code.
volcl::Volume pattern(volcl::Dims dims, volcl::ScalarType type, int frame) {
    volcl::Volume v(dims, type);
    volcl::codec::visitTyped(v, [&](auto values) {
        using T = typename decltype(values)::value_type;
        for (std::size_t i = 0; i < values.size(); ++i)
            values[i] = static_cast<T>((i * 7 + static_cast<std::size_t>(frame) * 3) % 97);
    });
    return v;
}

// Builds, before fuzzing, every kernel variant a decode of an encoder's file can ask for: voxel type x
// wavelet x lossless/lossy x line-buffer size (bricks up to 64, 128 and 256 voxels), I frames and P/B series.
// Each variant's first build on a machine runs PoCL's compiler (1-3 s and some 260 MB in this instrumented
// process), which a mutated input reaching a new variant would otherwise pay inside its 2 s and 500 MB.
// Builds are cached on disk: the first time takes about 9 minutes, later ones 12 s. scripts/fuzz.sh runs it
// before a long run, in a process of its own (VOLCL_FUZZ_BUILD_ALL_KERNELS=1, -runs=0), since the encodes
// leave an instrumented process near 1 GB; the short run in CI and the corpus replays do not.
void buildEveryDecodeKernel(volcl::ComputeContext& cc) {
    using namespace volcl;
    struct Shape {
        Dims dims, brick;
    };
    const Shape shapes[] = {
        {{16, 16, 16}, {16, 16, 16}}, {{100, 8, 8}, {128, 8, 8}}, {{200, 8, 8}, {256, 8, 8}}};
    for (const ScalarType type :
         {ScalarType::UInt8, ScalarType::UInt16, ScalarType::Int16, ScalarType::Float32})
        for (const Wavelet wavelet : {Wavelet::Cdf53, Wavelet::Cdf97, Wavelet::Haar, Wavelet::Cdf26})
            for (const bool lossless : {true, false})
                for (const bool series : {false, true}) {
                    if (lossless && !hasIntegerForm(wavelet)) continue;
                    CodecOptions options;
                    options.rate = lossless ? RateMode::Lossless : RateMode::Psnr;
                    options.target = 40;
                    options.step = lossless ? std::nullopt : std::optional<double>(1.0);
                    options.measureError = false;
                    options.wavelet = wavelet;
                    options.levels = 2;
                    options.bFrames = 1;
                    for (const Shape& shape : shapes) {
                        if (series && shape.brick.x > 16) continue; // the motion kernels do not depend on it
                        options.brick = shape.brick;
                        TimeSeries frames;
                        for (int f = 0; f < (series ? 3 : 1); ++f)
                            frames.frames.push_back(pattern(shape.dims, type, f));
                        std::vector<std::byte> bytes = series
                                                           ? encodeSeries(cc, frames, options)
                                                           : encodeVolume(cc, frames.frames.front(), options);
                        decodeEveryWay(cc, VczReader(std::move(bytes), "warm-up.vcz"));
                    }
                }
}

} // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
    volcl::ComputeContext& cc = computeContext();
    const char* all = std::getenv("VOLCL_FUZZ_BUILD_ALL_KERNELS");
    if (all && std::string_view(all) == "1") buildEveryDecodeKernel(cc);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace volcl;
    const auto* first = reinterpret_cast<const std::byte*>(data);
    std::vector<std::byte> bytes(first, first + size);
    try {
        // The harness's own budget: a forged size must be refused here, not exhaust the fuzzing machine.
        (void)readVczHeader(bytes, "fuzz.vcz", fuzz::kFuzzMemoryBudget);
        decodeEveryWay(computeContext(), VczReader(std::move(bytes), "fuzz.vcz"));
    } catch (const Error&) {
        // Refused as corrupt (IoError), unsupported (DataError) or out of range (UsageError): expected.
    }
    return 0;
}
