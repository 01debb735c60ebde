#pragma once
// A bucket queue for the graph's one-to-all searches (Dial's algorithm): keys are filed by
// key / width in a ring of buckets, where `width` is at most the cheapest step, so a node's
// step from a bucket lands in a later one and a bucket's nodes leave in any order. Not in
// key order within a bucket, so a caller relaxes as a label-correcting search does: it skips
// an entry whose key is above the node's distance by then, and pushes every improvement (a
// step that rounding leaves in the bucket being emptied is appended to it). With positive
// steps such a search ends at the same distances as Dijkstra's with a heap, bit for bit: both
// are the least fixpoint of d(m) = min over steps of float(d(n) + cost), which is the least
// float cost of a path, added along it. It is O(1) a push or pop instead of a heap's O(log n).
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace strata::graph_internal {

class BucketQueue {
 public:
  /// Keys of steps at least `width` (> 0) and at most `widest_step` (>= width) apart.
  BucketQueue(double width, double widest_step)
      : width_(width), buckets_(static_cast<std::size_t>(std::ceil(widest_step / width)) + 2) {}

  /// Files `node` under `key`: into an empty queue any key, else one no less than the last
  /// key popped and no more than widest_step above it (or, before any pop, above the first).
  void Push(float key, std::int32_t node) {
    if (size_ == 0) {  // The ring starts again at this key's bucket.
      buckets_[current_ % buckets_.size()].clear();
      next_ = 0;
      current_ = BucketOf(key);
    }
    // Rounding may put a key just below the bucket being emptied: it joins that one.
    const std::uint64_t bucket = std::max(BucketOf(key), current_);
    buckets_[bucket % buckets_.size()].emplace_back(key, node);
    ++size_;
  }

  /// The next entry, from the lowest bucket holding one; false when the queue is empty.
  bool Pop(float* key, std::int32_t* node) {
    while (size_ > 0) {
      std::vector<std::pair<float, std::int32_t>>& bucket = buckets_[current_ % buckets_.size()];
      if (next_ < bucket.size()) {
        *key = bucket[next_].first;
        *node = bucket[next_].second;
        ++next_;
        --size_;
        return true;
      }
      bucket.clear();
      next_ = 0;
      ++current_;
    }
    return false;
  }

 private:
  std::uint64_t BucketOf(float key) const {
    return static_cast<std::uint64_t>(static_cast<double>(key) / width_);
  }

  double width_;
  std::vector<std::vector<std::pair<float, std::int32_t>>> buckets_;
  std::uint64_t current_ = 0;  // The bucket being emptied.
  std::size_t next_ = 0;       // Its next entry.
  std::size_t size_ = 0;       // Entries pushed and not popped.
};

}  // namespace strata::graph_internal
