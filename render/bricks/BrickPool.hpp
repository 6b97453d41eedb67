// The brick cache's bookkeeping on the host: a buddy allocator over a device buffer of floats (blocks of
// 8^k granules) and the least-recently-used list of decoded bricks that live in it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <list>
#include <map>
#include <optional>
#include <set>
#include <tuple>
#include <unordered_map>
#include <vector>

namespace volcl {

/// Octal buddy allocator: the pool is `topCount` blocks of order `topOrder`; a block of order k holds
/// `granule * 8^k` floats and splits into 8 blocks of order k - 1. Decoded bricks at level l of a 2^L-aligned
/// brick need 1/8^l of a level-0 brick, so each level is one order down and nothing fragments below a block.
class BuddyAllocator {
public:
    BuddyAllocator(std::size_t granule, int topOrder, std::size_t topCount);
    std::size_t granule() const noexcept { return granule_; }
    int topOrder() const noexcept { return topOrder_; }
    std::size_t capacity() const noexcept { return blockFloats(topOrder_) * topCount_; } ///< floats
    std::size_t blockFloats(int order) const noexcept;
    /// Smallest order holding `floats` (-1 when larger than a top block).
    int orderFor(std::size_t floats) const noexcept;
    /// Float offset of a free block of `order`, or nothing when none is left.
    std::optional<std::size_t> allocate(int order);
    void release(std::size_t offset, int order);
    std::size_t usedFloats() const noexcept { return used_; }

private:
    std::size_t granule_;
    int topOrder_;
    std::size_t topCount_;
    std::vector<std::set<std::size_t>> free_; ///< per order: free block offsets in granules
    std::size_t used_ = 0;
};

/// What the cache holds per decoded brick.
struct CachedBrick {
    std::size_t offset = 0; ///< float offset in the pool's block area
    int order = 0;
    std::size_t floats = 0; ///< samples stored
};

/// Decoded bricks keyed by (frame, brick, level), least recently used first.
class BrickCache {
public:
    using Key = std::tuple<std::size_t, std::size_t, int>;
    /// Where repack() puts one brick of the working set.
    struct Placement {
        Key key;
        CachedBrick slot;
        bool resident = false; ///< it was in the pool: its samples move from `from` to slot.offset
        std::size_t from = 0;  ///< its float offset before the repack (resident bricks only)
    };
    explicit BrickCache(BuddyAllocator allocator) : alloc_(std::move(allocator)) {}

    const BuddyAllocator& allocator() const noexcept { return alloc_; }
    /// The entry for `key`, marked most recently used; nullptr when absent.
    const CachedBrick* touch(const Key& key);
    /// Whether `key` is resident (its place in the LRU order unchanged).
    bool holds(const Key& key) const { return entries_.count(key) != 0; }
    /// Space for `floats` samples under `key`, evicting least recently used entries not in `pinned`;
    /// nothing when even that does not free a block.
    std::optional<CachedBrick> insert(const Key& key, std::size_t floats, const std::set<Key>& pinned);
    /// Evicts every entry outside `workingSet` (keys and sample counts) and places the working set afresh,
    /// largest first: blocks of non-increasing order taken lowest offset first from an empty buddy allocator
    /// pack without holes, so a working set whose blocks sum to at most the capacity always fits (nothing
    /// is returned otherwise and the pool is left empty). Entries already in the pool keep their samples
    /// (the caller moves them); the others are entered too, and the caller fills their slots. Used when bricks
    /// kept from earlier frames fragment the pool: moving resident bricks instead of decoding them again.
    std::optional<std::vector<Placement>> repack(std::vector<std::pair<Key, std::size_t>> workingSet);
    std::size_t size() const noexcept { return entries_.size(); }
    std::size_t evictions() const noexcept { return evictions_; }
    void clear();

private:
    void releaseAll(); ///< frees every entry's block, counting no eviction
    BuddyAllocator alloc_;
    std::list<Key> lru_; ///< front: least recently used
    std::map<Key, std::pair<CachedBrick, std::list<Key>::iterator>> entries_;
    std::size_t evictions_ = 0;
};

} // namespace volcl
