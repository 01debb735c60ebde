#include "planning/clearance_ranks.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <iterator>
#include <limits>
#include <utility>

namespace strata::graph_internal {
namespace {

// Keeps `c` among the `kept` values of `heap` nearest the centre, `farther` ordering them
// farthest first (the heap's top).
template <typename Farther>
void Keep(float c, std::size_t kept, std::vector<float>& heap, Farther farther) {
  if (heap.size() < kept) {
    heap.push_back(c);
    std::push_heap(heap.begin(), heap.end(), farther);
  } else if (farther(c, heap.front())) {  // Nearer than the farthest kept.
    std::pop_heap(heap.begin(), heap.end(), farther);
    heap.back() = c;
    std::push_heap(heap.begin(), heap.end(), farther);
  }
}

// The farthest value of a full heap, NaN while it is not full (no comparison passes NaN).
float FarthestKept(const std::vector<float>& heap, std::size_t kept) {
  return heap.size() < kept ? std::numeric_limits<float>::quiet_NaN() : heap.front();
}

// One side's kept values (nearest first, `nearer` ordering them) less one copy each of
// `removed`, and with those of `added` that are at least as near as the farthest left: the
// invariant of ClearanceRanks holds for the side's values after the change.
template <typename Nearer>
std::vector<float> Changed(const std::vector<float>& kept, std::vector<float> removed,
                           std::vector<float> added, Nearer nearer) {
  std::sort(removed.begin(), removed.end(), nearer);
  std::vector<float> left;
  left.reserve(kept.size() + added.size());
  std::set_difference(kept.begin(), kept.end(), removed.begin(), removed.end(),
                      std::back_inserter(left), nearer);
  // With nothing left, no added value is known to be among the nearest.
  if (left.empty()) return left;
  const float farthest = left.back();
  std::erase_if(added, [&](float c) { return nearer(farthest, c); });
  std::sort(added.begin(), added.end(), nearer);
  const auto middle = static_cast<std::ptrdiff_t>(left.size());
  left.insert(left.end(), added.begin(), added.end());
  std::inplace_merge(left.begin(), left.begin() + middle, left.end(), nearer);
  // Bounded: the farthest go first, which keeps the invariant.
  if (left.size() > 2 * ClearanceRanks::kKept) left.resize(2 * ClearanceRanks::kKept);
  return left;
}

}  // namespace

void ClearanceRanks::Add(std::span<const SurfaceGraph::Node> nodes) {
  // Nearly every clearance lies farther from the centre than the farthest kept on its side
  // (once a side is full): those are only counted, and the rest go through Keep. The loop
  // works on locals; members would be stored and loaded back for every node.
  const float centre = centre_;
  std::size_t below = 0, at = 0;
  float farthest_below = FarthestKept(below_, kKept);
  float farthest_above = FarthestKept(above_, kKept);
  for (const SurfaceGraph::Node& node : nodes) {
    const float c = node.clearance_m;
    below += c < centre ? 1 : 0;
    at += c == centre ? 1 : 0;
    if (c <= farthest_below || c >= farthest_above || c == centre) continue;
    if (c < centre) {
      Keep(c, kKept, below_, std::greater<>());
      farthest_below = FarthestKept(below_, kKept);
    } else {
      Keep(c, kKept, above_, std::less<>());
      farthest_above = FarthestKept(above_, kKept);
    }
  }
  below_count_ += below;
  at_count_ += at;
}

void ClearanceRanks::Finish() {
  std::sort(below_.begin(), below_.end(), std::greater<>());
  std::sort(above_.begin(), above_.end(), std::less<>());
}

void ClearanceRanks::Update(std::span<const float> removed, std::span<const float> added) {
  std::vector<float> removed_below, removed_above, added_below, added_above;
  for (const float c : removed) {
    if (c == centre_) {
      --at_count_;
    } else if (c < centre_) {
      --below_count_;
      removed_below.push_back(c);
    } else {
      removed_above.push_back(c);
    }
  }
  for (const float c : added) {
    if (c == centre_) {
      ++at_count_;
    } else if (c < centre_) {
      ++below_count_;
      added_below.push_back(c);
    } else {
      added_above.push_back(c);
    }
  }
  below_ = Changed(below_, std::move(removed_below), std::move(added_below), std::greater<>());
  above_ = Changed(above_, std::move(removed_above), std::move(added_above), std::less<>());
}

std::optional<float> ClearanceRanks::AtRank(std::size_t rank) const {
  if (rank >= below_count_ && rank < below_count_ + at_count_) return centre_;
  if (rank >= below_count_ + at_count_ && rank - below_count_ - at_count_ < above_.size()) {
    return above_[rank - below_count_ - at_count_];
  }
  if (rank < below_count_ && below_count_ - 1 - rank < below_.size()) {
    return below_[below_count_ - 1 - rank];
  }
  return std::nullopt;
}

}  // namespace strata::graph_internal
