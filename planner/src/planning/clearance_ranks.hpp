#pragma once
// The ranks of a graph's node clearances around one value, kept with the graph so that a patch
// finds its 10th percentile (SurfaceGraph::open_ground_clearance_m) from what the edit removed
// and added, without a pass over every node: on the 1 km site that pass is 60 ms of a 10 m
// scan's 150 ms graph patch, where the update is a sort of a few thousand values.
#include <cstddef>
#include <optional>
#include <span>
#include <vector>

#include "strata/planning/surface_graph.hpp"

namespace strata::graph_internal {

class ClearanceRanks {
 public:
  /// Values kept on either side of the centre by Add: enough for thousands of edits of a
  /// 10 m square (each moves the rank by its few thousand nodes) before a pass counts again.
  static constexpr std::size_t kKept = std::size_t{1} << 16;

  /// Counts around `centre`, from no clearance at all.
  explicit ClearanceRanks(float centre) : centre_(centre) {}

  /// Counts the clearances of `nodes`, keeping up to kKept values nearest the centre on either
  /// side (a pass over a graph's nodes, a row at a time). Finish follows the last.
  void Add(std::span<const SurfaceGraph::Node> nodes);
  /// After the last Add: the ranks are ready for Update and AtRank.
  void Finish();

  /// The ranks after a graph lost the nodes of clearances `removed` and gained those of
  /// `added` (their order does not matter).
  void Update(std::span<const float> removed, std::span<const float> added);

  /// The clearance at `rank` in ascending order, when the counts and the values kept tell it
  /// (it is the centre, or one of the kept values).
  std::optional<float> AtRank(std::size_t rank) const;

  /// Bytes held, not counting the object itself.
  std::size_t MemoryBytes() const {
    return (below_.capacity() + above_.capacity()) * sizeof(float);
  }

 private:
  float centre_;
  std::size_t below_count_ = 0, at_count_ = 0;
  // The kept values below and above the centre, nearest first (heaps, farthest on top, until
  // Finish). Every counted value strictly nearer the centre than the farthest kept on its side
  // is kept: they are the nearest values of their side, some of the farthest's copies aside.
  std::vector<float> below_, above_;
};

}  // namespace strata::graph_internal
