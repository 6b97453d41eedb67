// Entropy decoding of an intra frame's first transform rounds on a thread of its own, before the device exists.
#pragma once

#include "core/runtime/HostMemoryPool.hpp"

#include <cstddef>
#include <memory>
#include <span>
#include <vector>

namespace volcl {

class VczReader;
namespace codec {
struct AheadHandover;
}

/// Entropy decodes frame `frame` of `reader` (an I frame, whole, at full resolution) on a thread of its own,
/// into batch memory from `pool`, round after round in the order the decoder transforms them, until the
/// decoder takes it over or `maxBytes` of batch memory are filled. A one-shot decode starts the OpenCL
/// platform meanwhile (on the calling thread: the driver's LLVM must be loaded on a thread that lives as long
/// as the process), which otherwise leaves a core idle. Pass it in DecodeOptions::ahead with a ComputeContext
/// built on the same pool; a decode it does not match (another frame, a region, a level, a P frame) decodes
/// everything itself. Nothing is decoded ahead for P/B frames or raw-bits files. Example:
/// ```
/// volcl::VczReader r(volcl::readFileBytes("head.vcz"), "head.vcz");
/// auto pool = std::make_shared<volcl::HostMemoryPool>();
/// volcl::DecodeAhead ahead(r, 0, pool);
/// volcl::ComputeContext cc({}, pool);
/// volcl::Volume v = r.decode(cc, {.ahead = &ahead});
/// ```
class DecodeAhead {
public:
    /// Batch memory decoded ahead at most: enough for the platform's start on two cores (a round of 8 MB
    /// takes 10-20 ms on one thread), bounded so a huge volume does not hold much memory twice.
    static constexpr std::size_t kMaxBytes = std::size_t(64) << 20;
    /// `reader` must outlive this object.
    DecodeAhead(const VczReader& reader, std::size_t frame, std::shared_ptr<HostMemoryPool> pool,
                std::size_t maxBytes = kMaxBytes);
    ~DecodeAhead(); ///< stops after the brick in hand and joins
    DecodeAhead(const DecodeAhead&) = delete;
    DecodeAhead& operator=(const DecodeAhead&) = delete;

    /// For the decoder: stops after the brick in hand and hands over what was decoded when it was decoded for
    /// `frame` of the file `file` (the reader's bytes) with exactly the bricks `varying` (empty otherwise, and
    /// on every later call).
    codec::AheadHandover take(std::span<const std::byte> file, std::size_t frame,
                              const std::vector<std::size_t>& varying);
    /// Waits until the thread has decoded all it will (every round within maxBytes, or up to a corrupt brick).
    void wait();
    /// Bricks decoded ahead so far (final once take() or wait() returned).
    std::size_t bricksDecoded() const noexcept;

private:
    struct State;
    std::unique_ptr<State> state_;
};

} // namespace volcl
