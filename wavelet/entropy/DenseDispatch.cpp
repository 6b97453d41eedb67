// Which dense kernels run: the vector tables found for this CPU at start, unless a test switch (or the
// environment variable VOLCL_DENSE_SCALAR=1) forces the scalar code.
#include "wavelet/entropy/DenseKernels.hpp"
#include "wavelet/entropy/TestSwitches.hpp"

#include <atomic>
#include <cstdlib>

namespace volcl {

namespace entropy {

namespace {

#ifdef VOLCL_DENSE_AVX512
const DenseDecoderKernels* const kDecoder = avx512DenseDecoderKernels();
const DenseEncoderKernels* const kEncoder = avx512DenseEncoderKernels();
#else
const DenseDecoderKernels* const kDecoder = nullptr;
const DenseEncoderKernels* const kEncoder = nullptr;
#endif

std::atomic<bool> gForceScalar{[] {
    const char* e = std::getenv("VOLCL_DENSE_SCALAR");
    return e != nullptr && *e != '\0' && *e != '0';
}()};
// The encoder's switch, apart so that tests can pair either encoder with either decoder.
std::atomic<bool> gForceScalarEncoder{gForceScalar.load()};

} // namespace

const DenseDecoderKernels* denseDecoderKernels() noexcept {
    return gForceScalar.load(std::memory_order_relaxed) ? nullptr : kDecoder;
}
const DenseEncoderKernels* denseEncoderKernels() noexcept {
    return gForceScalarEncoder.load(std::memory_order_relaxed) ? nullptr : kEncoder;
}

} // namespace entropy

bool denseDecoderSimdAvailable() noexcept {
    return entropy::kDecoder != nullptr;
}
void setDenseDecoderScalar(bool force) noexcept {
    entropy::gForceScalar.store(force, std::memory_order_relaxed);
}
bool denseDecoderIsScalar() noexcept {
    return entropy::denseDecoderKernels() == nullptr;
}
bool denseEncoderArithmeticMatchesTables() {
    return entropy::kEncoder == nullptr || entropy::kEncoder->arithmeticMatchesTables();
}
void setDenseEncoderScalar(bool force) noexcept {
    entropy::gForceScalarEncoder.store(force, std::memory_order_relaxed);
}
bool denseEncoderIsScalar() noexcept {
    return entropy::denseEncoderKernels() == nullptr;
}

} // namespace volcl
