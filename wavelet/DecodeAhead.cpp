// Decoding ahead: an I frame's first transform rounds entropy decoded on a thread while the device starts.
#include "wavelet/DecodeAhead.hpp"

#include "wavelet/Codec.hpp"
#include "wavelet/FrameDecoder.hpp"
#include "wavelet/transform/BrickTransform.hpp"

#include <atomic>
#include <thread>

namespace volcl {

struct DecodeAhead::State {
    const VczReader* reader = nullptr;
    std::size_t frame = 0;
    std::shared_ptr<HostMemoryPool> pool;
    std::size_t maxBytes = 0;
    std::vector<std::size_t> varying;
    codec::AheadHandover out;
    std::atomic<bool> stop{false};
    std::atomic<std::size_t> bricks{0};
    bool taken = false;
    std::thread thread;

    // Runs on the thread: rounds in the decoder's order, each slot as its fill step would write it. A brick
    // that fails to decode (a corrupt payload) ends the run; the decoder decodes it again and reports it.
    void run() noexcept {
        try {
            const VczHeader& h = reader->header();
            using Batch = BrickBatch<std::int32_t>; // float batches have the same layout (4-byte elements)
            std::size_t used = 0;
            for (const std::vector<codec::BrickGroup>& groups :
                 codec::batchRounds<std::int32_t>(h, varying)) {
                std::size_t bytes = 0;
                for (const codec::BrickGroup& g : groups)
                    bytes += Batch::bytesFor(g.dims, g.bricks.size());
                if (stop || used + bytes > maxBytes) return;
                // The round is complete (a block per group, a flag per slot) before any slot is filled, so
                // that stopping or failing anywhere leaves a round the decoder can take.
                codec::PrefilledRound round;
                std::size_t slots = 0;
                for (const codec::BrickGroup& g : groups) {
                    round.blocks.emplace_back(pool, Batch::bytesFor(g.dims, g.bricks.size()));
                    slots += g.bricks.size();
                }
                round.filled.assign(slots, 0);
                codec::PrefilledRound& r = out.rounds.emplace_back(std::move(round));
                used += bytes;
                std::size_t k = 0;
                for (const codec::BrickGroup& g : groups) {
                    const std::size_t pitch = Batch::pitchFor(g.dims.x);
                    auto* base = static_cast<std::int32_t*>(r.blocks[&g - groups.data()].data());
                    for (std::size_t i = 0; i < g.bricks.size(); ++i, ++k) {
                        if (stop) return;
                        const std::size_t b = g.bricks[i];
                        std::int32_t* slot = base + i * Batch::strideFor(g.dims);
                        out.corrections[b] = codec::entropyDecodeBrick(reader->bytes(), h, frame, b, 0, slot,
                                                                       pitch, reader->name());
                        codec::zeroRowPadding(slot, g.dims, pitch);
                        r.filled[k] = 1;
                        ++bricks;
                    }
                }
            }
        } catch (...) {
            // Decoded again (and reported) by the decoder; what was filled before stays valid.
        }
    }
};

DecodeAhead::DecodeAhead(const VczReader& reader, std::size_t frame, std::shared_ptr<HostMemoryPool> pool,
                         std::size_t maxBytes)
    : state_(std::make_unique<State>()) {
    State& s = *state_;
    s.reader = &reader;
    s.frame = frame;
    s.pool = std::move(pool);
    s.maxBytes = maxBytes;
    const VczHeader& h = reader.header();
    if (!s.pool || frame >= h.frames.size() || h.frames[frame].type != FrameType::I ||
        h.transform == TransformKind::RawBits)
        return;
    s.varying = codec::varyingBricks(reader.bytes(), h, frame, codec::allBricks(h));
    s.out.corrections.resize(h.brickCount());
    s.thread = std::thread([&s] { s.run(); });
}

DecodeAhead::~DecodeAhead() {
    state_->stop = true;
    if (state_->thread.joinable()) state_->thread.join();
}

codec::AheadHandover DecodeAhead::take(std::span<const std::byte> file, std::size_t frame,
                                       const std::vector<std::size_t>& varying) {
    State& s = *state_;
    s.stop = true;
    if (s.thread.joinable()) s.thread.join();
    if (s.taken || file.data() != s.reader->bytes().data() || frame != s.frame || varying != s.varying)
        return {};
    s.taken = true;
    // A round the thread opened but did not reach is still a valid round with no slot filled.
    return std::move(s.out);
}

void DecodeAhead::wait() {
    if (state_->thread.joinable()) state_->thread.join();
}

std::size_t DecodeAhead::bricksDecoded() const noexcept {
    return state_->bricks;
}

} // namespace volcl
