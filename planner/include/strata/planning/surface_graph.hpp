#pragma once
/// The traversable space of an assessed map as a graph of near-surface cells, built once per
/// (TerrainModel, TraversabilityParams) and shared read-only by every search on it (the server
/// caches one per robot profile). Start/goal snapping onto it lives here too.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <iterator>
#include <memory>
#include <numbers>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/status.hpp"

namespace strata {

namespace graph_internal {
class ClearanceRanks;
}  // namespace graph_internal

/// What a move between adjacent nodes costs beyond its length (SurfaceGraph::MoveCost): extra
/// near obstacles and near the rim, so that paths leave the optimiser room. The search's terms
/// (SearchConfig derives from this); the graph's landmarks measure costs under the defaults.
struct MoveCostTerms {
  /// Extra cost of a move whose clearance is 0, relative to its length [-], >= 0.
  double clearance_weight = 2.0;
  /// Obstacle distance below which moves cost extra [m], > 0. Keep it below the reference
  /// height: the ground itself is an obstacle, so open ground has d ≈ reference height.
  double clearance_margin_m = 0.2;
  /// Extra cost of a move onto the rim of the traversable ground, relative to its length
  /// [-], >= 0. Paths that hug a drop or a too-steep patch leave the optimiser no room.
  double rim_weight = 1.0;
  /// Distance to the rim (SurfaceGraph::edge_distance) below which moves cost extra [m], in
  /// (0, 1] (the graph keeps rim distances exact only up to 2 m).
  double rim_margin_m = 0.4;

  /// True when every move costs at least as much under these terms as under `other`: no
  /// weight and no margin below `other`'s (the extra cost grows with each).
  bool CostsAtLeast(const MoveCostTerms& other) const {
    return clearance_weight >= other.clearance_weight &&
           clearance_margin_m >= other.clearance_margin_m && rim_weight >= other.rim_weight &&
           rim_margin_m >= other.rim_margin_m;
  }
};

/// Near-surface cells and their connectivity.
///
/// Nodes: for every column (ix, iy) and every surface s of it that is valid ground, has
/// tilt <= max_tilt_rad and clearance >= body_height_m, and whose reference point (column
/// centre x, y, s.ground_z + reference_height) lies inside the grid: one node, the grid cell
/// holding that reference point. Nodes are stored column by column (x fastest), each column's
/// nodes lowest first.
///
/// Edges (undirected): node a in column (ix, iy) and node b in one of the 8 horizontally
/// neighbouring columns (|dx|, |dy| <= 1, not both 0; a diagonal only when both columns it
/// passes between hold a node within an axis step of a and of b, so no path cuts a corner or
/// slips through a one-cell diagonal line of untraversable ground, and either end judges the
/// move alike) are adjacent iff
/// |ground_z(a) - ground_z(b)| <= max_step_m + s·tan(max_tilt_rad), s the horizontal distance
/// between the column centres (r or r√2): a step the robot can climb on top of the steepest
/// slope it may drive. (Real maps are often voxelised, e.g. the shared maps at 0.2 m: their
/// ramps are staircases whose risers this allows.) Nodes of the same column are never
/// adjacent. When the limit is below the grid resolution the two reference cells are at most
/// one layer apart, so this is 26-connectivity of the grid restricted to near-surface cells,
/// with the step rule deciding which of the candidate cells of a neighbour column joins.
///
/// Connected components are labelled at build, so reachability is an O(1) query.
class SurfaceGraph {
 public:
  /// One node: a traversable surface of a column.
  struct Node {
    std::int32_t ix, iy;
    std::int16_t surface_index;  ///< Index in SurfaceMap::Column(ix, iy).
    std::int16_t level;          ///< Among the column's valid surfaces, 0 = lowest.
    float reference_z_m;
    float clearance_m;
  };

  /// Builds the graph; it keeps a reference to `model`, which must outlive it. Fails with
  /// kInvalidConfig naming the bad field of `params`, or when params.max_tilt_rad exceeds the map's
  /// ground filter θ (naming both values); with kCancelled when `should_stop` (may be empty,
  /// polled every grid row and every few thousand nodes: milliseconds apart) returns true.
  static Expected<SurfaceGraph> Build(const TerrainModel& model, const TraversabilityParams& params,
                                      const std::function<bool()>& should_stop = {});

  /// The graph Build makes of `model` (which must outlive it), made from `base`, the graph of
  /// another model on the same grid for the same params, instead of built: `model` must
  /// differ from base.model() only in the surfaces and fields of `changed_columns` (their z
  /// ignored), as an edit's reassessed model differs from its base
  /// (Reassessment::changed_columns). The nodes of those columns and the next (whose
  /// clearance reads their fields) are found again, the rest copied; the rim distances are
  /// measured again within the cap of them; the components are labelled again over the
  /// whole graph (cheaply: the moves along the axes join what every move joins); landmarks
  /// are chosen as Build chooses them, and the distances from one the base had too are
  /// updated from the base's where the edit can change them (dynamic shortest paths) instead
  /// of searched again. Equals Build's graph, value for value (an edit of a 10 m square on a
  /// 400 m site: about a tenth of Build's time). Fails with kInvalidInput when the grids differ,
  /// and as Build does.
  static Expected<SurfaceGraph> Patch(const SurfaceGraph& base, const TerrainModel& model,
                                      const CellBox& changed_columns,
                                      const std::function<bool()>& should_stop = {});

  /// What a graph holds beyond what the model and the params give: the nodes themselves follow
  /// from those (the class comment says which surfaces are nodes, in which order), their
  /// measurements and labels do not. A saved graph (strata/io/saved_graph.hpp) stores these.
  struct Parts {
    TraversabilityParams params;
    std::vector<float> clearance_m;        ///< Per node: clearance(node).
    std::vector<std::int32_t> components;  ///< Per node: component(node).
    int component_count = 0;
    std::vector<float> edge_distance_m;  ///< Per node: edge_distance(node).
    double open_ground_clearance_m = 0;
    int landmark_count = 0;
    std::vector<float> landmark_distance;  ///< Node-major: landmark_count per node.
  };
  /// The graph of `model` for parts.params with the measurements of `parts` (which
  /// `model` must outlive), without building: the nodes are found again from the model
  /// (one pass over its columns, no field lookups), the rest is taken as given. Fails with
  /// kInvalidConfig as Build does for bad params, and with kMapLoadFailed when `parts` do not
  /// fit the nodes: another node count (parts of another model or other params), a component
  /// label out of range, a distance that is NaN or negative. What it cannot tell is whether
  /// the values are the ones Build measures: that is the saved graph's checksum's and its
  /// name's job (a graph is saved beside the model it was built on).
  static Expected<SurfaceGraph> FromParts(const TerrainModel& model, Parts parts);

  /// Per node, in node order: clearance, component, rim distance; and the landmark distances
  /// (node-major). What Parts holds, read in place (a saved graph writes them from here).
  std::span<const Node> nodes() const { return nodes_; }
  std::span<const std::int32_t> components() const { return components_; }
  std::span<const float> edge_distances() const { return edge_distance_; }
  std::span<const float> landmark_distances() const { return landmark_distance_; }

  const TerrainModel& model() const { return *model_; }
  const TraversabilityParams& params() const { return params_; }
  const GridGeometry& grid() const { return model_->grid(); }

  int node_count() const { return static_cast<int>(nodes_.size()); }
  int component_count() const { return component_count_; }
  /// Connected component label of `node`, in [0, component_count()).
  int component(int node) const { return components_[node]; }

  /// Reference point of `node` [m]: column centre x, y; ground height + reference_height_m.
  Eigen::Vector3d position(int node) const {
    const Node& n = nodes_[node];
    const GridGeometry& g = grid();
    return {g.origin_m.x() + (n.ix + 0.5) * g.resolution_m,
            g.origin_m.y() + (n.iy + 0.5) * g.resolution_m, static_cast<double>(n.reference_z_m)};
  }
  /// Ground height under `node` [m].
  double ground_z(int node) const {
    return static_cast<double>(nodes_[node].reference_z_m) - params_.reference_height_m;
  }
  /// Grid cell holding the node's reference point.
  Eigen::Vector3i cell(int node) const { return grid().CellOf(position(node)); }
  /// Column of `node`.
  Eigen::Vector2i column(int node) const { return {nodes_[node].ix, nodes_[node].iy}; }
  /// Index of the node's surface among the valid surfaces of its column, 0 = lowest.
  int level(int node) const { return nodes_[node].level; }
  /// Free height above the node's ground up to the next obstacle in its column [m]
  /// (ColumnSurface::clearance_m; +infinity under open sky).
  double ceiling_clearance(int node) const { return surface(node).clearance_m; }
  /// The column surface the node stands on.
  const ColumnSurface& surface(int node) const {
    const Node& n = nodes_[node];
    return model_->surfaces().Column(n.ix, n.iy)[static_cast<std::size_t>(n.surface_index)];
  }
  /// Obstacle distance d at the reference point (TerrainModel::Distance) [m].
  double clearance(int node) const { return nodes_[node].clearance_m; }

  /// The node indices of one column, [first, end): consecutive, since nodes are stored column
  /// by column. (std::ranges::iota_view would do, but clang 14, which runs the project's
  /// clang-tidy, cannot compile libstdc++ 12's ranges.)
  class NodeRange {
   public:
    class Iterator {
     public:
      using iterator_category = std::forward_iterator_tag;
      using value_type = std::int32_t;
      using difference_type = std::ptrdiff_t;
      using pointer = const std::int32_t*;
      using reference = std::int32_t;
      Iterator() = default;
      explicit Iterator(std::int32_t node) : node_(node) {}
      std::int32_t operator*() const { return node_; }
      Iterator& operator++() {
        ++node_;
        return *this;
      }
      Iterator operator++(int) {
        const Iterator before = *this;
        ++node_;
        return before;
      }
      bool operator==(const Iterator& other) const = default;

     private:
      std::int32_t node_ = 0;
    };
    NodeRange() = default;
    NodeRange(std::int32_t first, std::int32_t end) : first_(first), end_(end) {}
    Iterator begin() const { return Iterator(first_); }
    Iterator end() const { return Iterator(end_); }
    std::size_t size() const { return static_cast<std::size_t>(end_ - first_); }
    bool empty() const { return first_ == end_; }
    std::int32_t operator[](std::size_t k) const { return first_ + static_cast<std::int32_t>(k); }

   private:
    std::int32_t first_ = 0;
    std::int32_t end_ = 0;
  };
  /// Node indices of column (ix, iy), lowest first; empty outside the grid.
  NodeRange ColumnNodes(int ix, int iy) const {
    const GridGeometry& g = grid();
    if (ix < 0 || iy < 0 || ix >= g.size.x() || iy >= g.size.y()) return {};
    const auto c = static_cast<std::size_t>(ix + std::int64_t{g.size.x()} * iy);
    return {static_cast<std::int32_t>(column_begin_[c]),
            static_cast<std::int32_t>(column_begin_[c + 1])};
  }

  /// Calls f(neighbour_node) for every node adjacent to `node` (see the class comment).
  template <typename F>
  void ForEachNeighbor(int node, F&& f) const {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx != 0 || dy != 0) ForEachNeighborToward(node, dx, dy, f);
      }
    }
  }

  /// Calls f(neighbour_node) for every node adjacent to `node` in the column (dx, dy) away,
  /// dx and dy in {-1, 0, 1} and not both 0: one direction of ForEachNeighbor.
  template <typename F>
  void ForEachNeighborToward(int node, int dx, int dy, F&& f) const {
    const Node& n = nodes_[node];
    const bool diagonal = dx != 0 && dy != 0;
    const float limit = diagonal ? step_limit_diagonal_ : step_limit_axis_;
    for (const std::int32_t m : ColumnNodes(n.ix + dx, n.iy + dy)) {
      if (!(std::abs(nodes_[m].reference_z_m - n.reference_z_m) <= limit)) continue;
      // No corner cutting: a diagonal move needs both columns it passes between, each with a
      // node within an axis step of both ends, so that it is judged alike from either end
      // (the graph is undirected).
      if (diagonal && !(HasStepNeighbor(n, nodes_[m], n.ix + dx, n.iy) &&
                        HasStepNeighbor(n, nodes_[m], n.ix, n.iy + dy))) {
        continue;
      }
      f(int{m});
    }
  }

  /// The obstacle distance nine nodes in ten keep at least [m] (0 for an empty graph). On open
  /// ground that is the ground's own distance below the reference point: about the reference
  /// height, less on a coarse grid (the biped's 0.2 m on a 0.2 m grid: 0.11 m). A clearance
  /// margin above it is one no path can keep (ShortenPath caps its margin just under it).
  double open_ground_clearance_m() const { return open_ground_clearance_m_; }
  /// Distance from the node's column centre to the rim of the traversable region it belongs
  /// to [m]: 0.5·r for a node missing any of its 8 neighbours (its column borders
  /// non-traversable ground), growing inwards along graph edges (chamfer distance), up to
  /// EdgeDistanceCap(r); nodes farther in read the cap.
  double edge_distance(int node) const { return edge_distance_[node]; }
  /// Where edge distances stop growing [m]: 2 m, plus two diagonal steps so that values up to
  /// 2 m interpolate exactly between columns. Its readers' margins stay below 1 m
  /// (MoveCostTerms::rim_margin_m, CostConfig::edge_margin_m), so capping changes nothing for
  /// them, and only the nodes within the cap of a rim are visited: a fraction of a big map.
  static double EdgeDistanceCap(double resolution_m) {
    return 2.0 + 2.0 * std::numbers::sqrt2 * resolution_m;
  }
  /// The node of column (ix, iy) whose ground is nearest to ground_z and within 0.5 m of it
  /// (the same level), or -1.
  int NodeNear(int ix, int iy, double ground_z) const;
  /// NodeNear at ground height `height`, and an open band (*low, *high) of ground heights
  /// around it over which NodeNear gives the same node (empty, low >= high, where it gives -1).
  int NodeNear(int ix, int iy, double height, double* low, double* high) const;
  /// Heights further apart than this are different levels [m].
  static constexpr double kLevelGapM = 0.5;

  /// Cost of moving between adjacent nodes a and b under `terms`: the Euclidean 3D length
  /// between their reference points times 1 + w_c · max(0, margin_c − c) / margin_c +
  /// w_r · max(0, margin_r − e) / margin_r, with c the smaller clearance and e the smaller rim
  /// distance of the two. Never below the length.
  double MoveCost(int a, int b, const MoveCostTerms& terms) const {
    const double length = (position(a) - position(b)).norm();
    const double c = std::min(clearance(a), clearance(b));
    const double shortfall = std::max(0.0, terms.clearance_margin_m - c);
    const double e = std::min(edge_distance(a), edge_distance(b));
    const double rim_shortfall = std::max(0.0, terms.rim_margin_m - e);
    return length * (1.0 + terms.clearance_weight * shortfall / terms.clearance_margin_m +
                     terms.rim_weight * rim_shortfall / terms.rim_margin_m);
  }

  /// A lower bound on the cost (MoveCost under `terms`) of every path over graph edges
  /// between nodes a and b, from the landmarks (ALT: Goldberg and Harrelson, 2005): the max
  /// over landmarks L of |d_L(a) − d_L(b)| (triangle inequality), d_L the least cost of a
  /// path from L under the default MoveCostTerms. It bounds the cost under any `terms` that
  /// cost at least as much (CostsAtLeast); under others, and without landmarks, it is 0. The
  /// straight-line distance bounds every cost too; the search takes the larger. Where the
  /// straight line crosses a spiral's core, the landmarks know the way round, and along a
  /// ramp they know that the cheapest path keeps off its rim.
  double LandmarkBound(int a, int b, const MoveCostTerms& terms) const {
    if (landmark_count_ == 0 || !terms.CostsAtLeast(MoveCostTerms{})) return 0;
    const float* la = &landmark_distance_[static_cast<std::size_t>(a) * landmark_count_];
    const float* lb = &landmark_distance_[static_cast<std::size_t>(b) * landmark_count_];
    // Every landmark lies in one component (ComputeLandmarks): a node's distances are all
    // finite, or all infinite (it lies outside that component), and then there is no bound.
    if (!std::isfinite(la[0]) || !std::isfinite(lb[0])) return 0;
    double gap = 0;
    for (int k = 0; k < landmark_count_; ++k) {
      gap = std::max(gap, std::abs(double{la[k]} - double{lb[k]}));
    }
    // Float distances are shrunk by a part in 10⁵, more than their rounding, so the bound
    // stays below the true cost.
    return (1 - 1e-5) * gap;
  }
  /// Whether A* from `start` to `goal` had better search from the goal back to the start.
  /// The landmark that gives LandmarkBound(start, goal) lies nearer one end, and from that
  /// end the bound is flat: every node whose cheapest path from the landmark passes through
  /// that end has the same g + bound, a plateau A* must flood (on a spiral ramp its whole
  /// width, every turn), where from the other end the bound rises across it. So: true when
  /// the largest bound from landmarks nearer the start exceeds the largest from landmarks
  /// nearer the goal. False where LandmarkBound(start, goal, terms) is 0 (no landmarks,
  /// other terms, other components).
  bool ShouldSearchBackward(int start, int goal, const MoveCostTerms& terms) const;
  /// Landmarks kept for LandmarkBound: kMaxLandmarks in the largest component of a graph
  /// of at most kMaxLandmarkNodes nodes, else none (their Dijkstra runs would cost seconds
  /// on a site-scale graph, whose open ground the straight line already bounds well).
  int landmark_count() const { return landmark_count_; }
  static constexpr int kMaxLandmarks = 8;
  static constexpr int kMaxLandmarkNodes = 1'000'000;

  /// Bytes held by the graph, not counting the object itself.
  std::size_t MemoryBytes() const {
    return nodes_.capacity() * sizeof(Node) + column_begin_.capacity() * sizeof(std::uint32_t) +
           components_.capacity() * sizeof(std::int32_t) +
           edge_distance_.capacity() * sizeof(float) +
           landmark_distance_.capacity() * sizeof(float) +
           seed_distance_.capacity() * sizeof(float) + OpenRanksBytes();
  }

 private:
  SurfaceGraph(const TerrainModel& model, const TraversabilityParams& params);
  // kInvalidConfig when `params` are invalid or steeper than the map's ground filter allows.
  static Status CheckParams(const TerrainModel& model, const TraversabilityParams& params);
  // Finds the nodes of model_ for params_ (nodes_, column_begin_), each with
  // its clearance measured or 0; false when `stopped` fired.
  bool CollectNodes(const std::function<bool()>& stopped, bool measure_clearance);
  // Appends the nodes of column (ix, iy) to nodes_ (CollectNodes).
  void AppendColumnNodes(int ix, int iy, bool measure_clearance);
  // The 10th percentile of the nodes' clearances (open_ground_clearance_m).
  double ClearanceTenthPercentile() const;
  // Sets open_ground_clearance_m_ and open_ranks_ from the base's ranks, updated for the
  // clearances of the nodes of `renewed` in the base and here, or from `counted` (the ranks
  // of every node, counted around the base's value; null when the base has ranks), or else
  // from a count of every node (surface_graph_patch.cpp).
  void PatchOpenGroundClearance(const SurfaceGraph& base, const CellBox& renewed,
                                graph_internal::ClearanceRanks* counted);
  std::size_t OpenRanksBytes() const;
  // Into *pieces, the parts the nodes of each component with nodes in `columns` fall into
  // without them, but for one part each that keeps the component's label (the one that may go
  // on far from `columns`): each part a list of its nodes. They are found within a ring of
  // columns around `columns` (PiecesWithinRing, rings ever wider); false when the widest ring
  // cannot tell whether two parts meet beyond it (surface_graph_patch.cpp).
  bool PiecesWithout(const CellBox& columns, std::vector<std::vector<std::int32_t>>* pieces) const;
  // PiecesWithout within the ring of `ring_columns` columns around `columns`.
  bool PiecesWithinRing(const CellBox& columns, int ring_columns,
                        std::vector<std::vector<std::int32_t>>* pieces) const;
  // Labels the components of a graph patched from `base` from the base's labels, which
  // components_ holds outside `renewed` (anything inside), and the `pieces` that
  // base.PiecesWithout(renewed) found. False when `stopped` fired.
  bool LabelComponentsAcross(const SurfaceGraph& base, const CellBox& renewed,
                             const std::vector<std::vector<std::int32_t>>& pieces,
                             const std::function<bool()>& stopped);
  // The least costs from a node to every node (infinity where unreached) into *distance;
  // false when the search was stopped.
  using DistancesFrom = std::function<bool(int source, std::vector<float>* distance)>;
  // Chooses landmarks and fills landmark_distance_ and seed_distance_, each table from
  // `distances_from` (surface_graph_landmarks.cpp); false when it was stopped.
  bool ChooseLandmarks(const DistancesFrom& distances_from);
  // ChooseLandmarks, every table searched over the whole graph.
  bool ComputeLandmarks(const std::function<bool()>& should_stop);
  // ChooseLandmarks, a table the base has (measured from the same node) updated from the
  // base's instead (UpdateDistances). Outside `changed_columns` the nodes are the base's, with
  // the same clearances and rim distances.
  bool PatchLandmarks(const SurfaceGraph& base, const CellBox& changed_columns,
                      const std::function<bool()>& should_stop);
  // Sets edge_distance_ from the nodes of the rim; false when should_stop fired.
  bool ComputeEdgeDistances(const std::vector<std::int32_t>& rim,
                            const std::function<bool()>& should_stop);
  // Whether column (ix, iy) has a node an axis step away from both a and b.
  bool HasStepNeighbor(const Node& a, const Node& b, int ix, int iy) const {
    for (const std::int32_t m : ColumnNodes(ix, iy)) {
      const float z = nodes_[m].reference_z_m;
      if (std::abs(z - a.reference_z_m) <= step_limit_axis_ &&
          std::abs(z - b.reference_z_m) <= step_limit_axis_) {
        return true;
      }
    }
    return false;
  }

  const TerrainModel* model_ = nullptr;
  TraversabilityParams params_;
  // Largest ground height change to an axis / diagonal neighbour column (see the class
  // comment), as compared in float.
  float step_limit_axis_ = 0;
  float step_limit_diagonal_ = 0;
  std::vector<Node> nodes_;
  std::vector<std::uint32_t> column_begin_;  // Columns + 1: each column's first node.
  std::vector<std::int32_t> components_;
  int component_count_ = 0;
  std::vector<float> edge_distance_;
  double open_ground_clearance_m_ = 0;
  int landmark_count_ = 0;
  std::vector<float> landmark_distance_;  // Node-major: landmark_count_ floats per node.
  // The ranks of the clearances around open_ground_clearance_m_, which the next Patch updates
  // (null until a patch counts them: Build and FromParts do not).
  std::shared_ptr<const graph_internal::ClearanceRanks> open_ranks_;
  // The distances from the node the landmarks were chosen from (the first of the largest
  // component), which Patch updates to choose the first landmark again. Not saved: a patch of
  // a loaded graph searches them again.
  std::vector<float> seed_distance_;
};

/// Where a 3D start or goal lands on the graph.
struct SnapResult {
  int node = -1;                                         ///< Graph node snapped to.
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  ///< Its reference point [m].
  /// Index of the node's surface among the valid surfaces of its column, 0 = lowest.
  int level = 0;
  double distance_m = 0;  ///< Level distance from the query point (see SnapToSurface) [m].
};

/// Snaps `p` onto the graph. Distances are "level distances": the horizontal distance to the
/// node's reference point combined (hypot) with how far p.z lies outside that level's free
/// space (from its ground − half a cell up to its ceiling, at most 2.5 m above its ground), so
/// any z within a level's air space selects that level. First choice: p's own column, at the level
/// p's z points at (the highest node whose ground is at or below p.z + half a cell), if within
/// `tolerance_m`. Otherwise the node within tolerance_m that minimises the distance, with a strong
/// preference for nodes whose ground lies below p.z. Fails with kInvalidInput for a non-finite p or
/// tolerance < 0, and with `off_ground_code` (kStartOffGround or kGoalOffGround) when no node is
/// within tolerance; the message names p, the tolerance, and the nearest node anywhere on the map.
/// `accept` (may be empty) restricts the nodes snapped to (e.g. those whose reference point
/// keeps the verifier's distance from obstacles); when it turns down every node within
/// tolerance, the message says so and names `refusal`, what the turned-down nodes lack.
Expected<SnapResult> SnapToSurface(const SurfaceGraph& graph, const Eigen::Vector3d& p,
                                   double tolerance_m, ErrorCode off_ground_code,
                                   const std::function<bool(int node)>& accept = {},
                                   std::string_view refusal = {});

}  // namespace strata
