#pragma once
/// A*'s per-node state (cost so far, parent, closed) for the part of the graph one search
/// reaches: a plan's set-up time and memory grow with the area it explores, not with the graph
/// (a 5 m plan on a kilometre-wide site reaches a few hundred of its tens of millions of
/// nodes).
///
/// Nodes are numbered column by column (SurfaceGraph), so a search's neighbours mostly have
/// nearby ids. The state is kept in pages of kPageNodes consecutive ids, allocated when a node
/// of the page is first touched, and found through a directory of 4 bytes per page of the
/// graph (0.4 MB for 25 million nodes, cleared per plan in a few microseconds). Measured on the
/// spiral's long queries: within a few percent of arrays the size of the graph, where a hash
/// table of single nodes scattered neighbours and cost 50-65% more search time.

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace strata::internal {

class SearchState {
 public:
  struct Entry {
    double g = std::numeric_limits<double>::infinity();  ///< Cost so far; ∞ = not reached.
    std::int32_t parent = -1;
    bool closed = false;
  };

  /// State for a graph of `node_count` nodes, nothing reached.
  explicit SearchState(std::int32_t node_count)
      : directory_((static_cast<std::size_t>(node_count) >> kPageBits) + 1, 0) {}

  /// The entry of `node`, fresh (g = ∞, no parent, open) the first time. The reference stays
  /// valid for the state's lifetime.
  Entry& At(std::int32_t node) {
    std::uint32_t& page = directory_[static_cast<std::size_t>(node) >> kPageBits];
    if (page == 0) {
      pages_.push_back(std::make_unique<Entry[]>(kPageNodes));
      page = static_cast<std::uint32_t>(pages_.size());  // 1-based: 0 means absent.
    }
    return pages_[page - 1][node & (kPageNodes - 1)];
  }

  /// Bytes held.
  std::size_t MemoryBytes() const {
    return directory_.capacity() * sizeof(std::uint32_t) + pages_.capacity() * sizeof(pages_[0]) +
           pages_.size() * kPageNodes * sizeof(Entry);
  }

 private:
  static constexpr int kPageBits = 8;
  static constexpr std::int32_t kPageNodes = std::int32_t{1} << kPageBits;

  std::vector<std::uint32_t> directory_;  // Per page of the graph: index into pages_ + 1.
  std::vector<std::unique_ptr<Entry[]>> pages_;
};

}  // namespace strata::internal
