#include "strata/verification/trajectory_verifier.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "format_internal.hpp"
#include "strata/planning/terrain_query.hpp"
#include "strata/verification/polynomial_bounds.hpp"

namespace strata {
namespace {

// "at t = 12.34 s, (x, y, z): <what>".
Error Violation(double t, const Eigen::Vector3d& p, const std::string& what) {
  return Error{ErrorCode::kOptimizationFailed,
               fmt::format("trajectory verification failed at t = {:.3f} s, {}: {}", t,
                           internal::FormatPoint(p), what)};
}

std::string Exceeds(const char* quantity, double value, double bound, const char* unit) {
  return fmt::format("{} {:.4g} {} exceeds the bound {:.4g} {}", quantity, value, unit, bound,
                     unit);
}

// Most samples one verification takes (2e7 samples 2 cm apart: 400 km).
constexpr double kMaxSamples = 2e7;

// The shortest stretch between two checked instants that the verifier still splits when it
// cannot show a rule over the stretch [s]: below it, the stretch is refused.
constexpr double kShortestStretchS = 1e-9;

// How far past its column's edge an enclosure of the path may reach and still count as inside
// it [m]: the instant a column is entered is found to kShortestStretchS, in which the path
// moves far less.
constexpr double kColumnEdgeSlackM = 1e-6;

// Branch and bound settles a kinematic maximum to this fraction of its bound for the report,
// and, where that leaves it undecided against the bound, to the second.
constexpr double kReportTolerance = 1e-4;
constexpr double kDecisionTolerance = 1e-9;

constexpr double kDegree = std::numbers::pi / 180.0;

// `surface` if it is one of column `cell`'s surfaces, else nullptr.
const ColumnSurface* SurfaceOfColumn(const TerrainModel& model, const Eigen::Vector3i& cell,
                                     const ColumnSurface* surface) {
  for (const ColumnSurface& s : model.surfaces().Column(cell.x(), cell.y())) {
    if (&s == surface) return surface;
  }
  return nullptr;
}

// Whether `graph` has a node on `surface` in column `cell`.
bool HasNodeOn(const SurfaceGraph& graph, const Eigen::Vector3i& cell,
               const ColumnSurface* surface) {
  for (const std::int32_t node : graph.ColumnNodes(cell.x(), cell.y())) {
    if (&graph.surface(node) == surface) return true;
  }
  return false;
}

}  // namespace

Status VerifierConfig::Validate(std::string_view path) const {
  if (!(std::isfinite(max_sample_spacing_m) && max_sample_spacing_m > 0)) {
    return internal::OutOfRange(internal::FieldPath(path, "max_sample_spacing_m"),
                                max_sample_spacing_m, "> 0");
  }
  if (!(std::isfinite(ground_tolerance_m) && ground_tolerance_m > 0)) {
    return internal::OutOfRange(internal::FieldPath(path, "ground_tolerance_m"), ground_tolerance_m,
                                "> 0");
  }
  if (!(std::isfinite(min_obstacle_distance_m) && min_obstacle_distance_m >= 0)) {
    return internal::OutOfRange(internal::FieldPath(path, "min_obstacle_distance_m"),
                                min_obstacle_distance_m, ">= 0");
  }
  if (!(std::isfinite(limit_tolerance) && limit_tolerance >= 0)) {
    return internal::OutOfRange(internal::FieldPath(path, "limit_tolerance"), limit_tolerance,
                                ">= 0");
  }
  return Status::Ok();
}

double BodyHeightTolerance(const RobotProfile& profile, const VerifierConfig& config) {
  return config.limit_tolerance *
         (profile.active_height ? profile.body_height_max_m : profile.body_height_m);
}

namespace {

// One piece as polynomials of local time: position, velocity and acceleration per axis, and a
// bound on its x, y, z speed.
struct PiecePolynomials {
  PiecePolynomials(const TrajectoryPiece& piece, int dimension) : duration_s(piece.duration_s) {
    for (int axis = 0; axis < dimension; ++axis) {
      position[axis] = piece.coefficients.col(axis);
      velocity[axis] = Derivative(position[axis]);
      acceleration[axis] = Derivative(velocity[axis]);
    }
    const Polynomial speed_squared = Product(velocity[0], velocity[0]) +
                                     Product(velocity[1], velocity[1]) +
                                     Product(velocity[2], velocity[2]);
    // A bound, not the maximum: 0.1% above it costs 0.1% more samples.
    const double coarse = RangeOn(speed_squared, 0, duration_s).high;
    const PolynomialMaximum peak = MaximumOn(speed_squared, 0, duration_s, 1e-3 * coarse);
    speed_bound_mps = std::sqrt(std::max(0.0, peak.upper));
  }

  // The enclosure of the x, y, z path over local times [a, b].
  Eigen::AlignedBox3d PathBox(double a, double b) const {
    Eigen::AlignedBox3d box;
    for (int axis = 0; axis < 3; ++axis) {
      const PolynomialRange range = RangeOn(position[axis], a, b);
      box.min()(axis) = range.low;
      box.max()(axis) = range.high;
    }
    return box;
  }

  double duration_s;
  Polynomial position[4], velocity[4], acceleration[4];
  double speed_bound_mps = 0;  // >= ‖(vx, vy, vz)‖ over the whole piece.
};

// The maximum of p over [0, duration], settled far enough to say whether it exceeds `limit`
// (on p's own scale): to kReportTolerance of the limit, and to kDecisionTolerance when the
// maximum found is within the limit but its bound is not.
PolynomialMaximum MaximumAgainst(const Polynomial& p, double duration, double limit) {
  const double scale = std::max(std::abs(limit), 1e-12);
  PolynomialMaximum m = MaximumOn(p, 0, duration, kReportTolerance * scale);
  if (!(m.upper <= limit) && m.value <= limit) {
    m = MaximumOn(p, 0, duration, kDecisionTolerance * scale);
  }
  return m;
}

// The largest of ‖(q_0, q_1)‖ (two axes) or |q_0| (one) over a piece, against `limit`
// (MaximumAgainst), with the local time where it is reached.
struct NormMaximum {
  double upper = 0;  // >= the norm everywhere on the piece.
  double value = 0;  // The norm at `at`.
  double at = 0;
};
NormMaximum LargestNorm(const Polynomial* axes, int count, double duration, double limit) {
  if (count == 2) {
    const Polynomial squared = Product(axes[0], axes[0]) + Product(axes[1], axes[1]);
    const PolynomialMaximum m = MaximumAgainst(squared, duration, limit * limit);
    return {std::sqrt(std::max(0.0, m.upper)), std::sqrt(std::max(0.0, m.value)), m.at};
  }
  const PolynomialMaximum up = MaximumAgainst(axes[0], duration, limit);
  const PolynomialMaximum down = MaximumAgainst(-axes[0], duration, limit);
  const PolynomialMaximum& m = up.upper >= down.upper ? up : down;
  return {m.upper, m.value, m.at};
}

// The instant the verifier last checked, and what held there.
struct CheckedInstant {
  double t = -1;                                     // Global time [s]; < 0 before the first.
  std::size_t piece = 0;                             // The piece the stretch from here on lies in.
  double piece_start = 0;                            // Its global start [s].
  Eigen::Vector2d column = Eigen::Vector2d::Zero();  // Floored cell coordinates.
  GridGeometry::OffsetRange x{0, 0}, y{0, 0};        // The column's (GridGeometry).
  const ColumnSurface* surface = nullptr;
  double distance_m = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};

// The checks of one instant, one function per rule of VerifyTrajectory's list, in its order,
// each recording its figure in the report first, and the proofs that the rules hold between
// consecutive instants. Every comparison is written !(value within bound), so a NaN fails it.
class StateChecker {
 public:
  StateChecker(const SurfaceGraph& graph, const RobotProfile& profile, const VerifierConfig& config,
               const Trajectory& trajectory, const std::vector<PiecePolynomials>& pieces,
               std::span<const KeepOutZone> keep_out, VerificationReport* report)
      : graph_(graph),
        model_(graph.model()),
        grid_(graph.grid()),
        profile_(profile),
        config_(config),
        pieces_(pieces),
        cursor_(trajectory),
        keep_out_(keep_out),
        report_(report),
        tolerance_(1 + config.limit_tolerance),
        body_slack_m_(BodyHeightTolerance(profile, config)),
        // A voxelised cloud knows its ground only to within half a quantum; the check allows
        // that plus a quarter quantum of tracking, or every staircase ramp would fail it by
        // noise.
        ground_tolerance_m_(
            std::max(config.ground_tolerance_m, 0.75 * model_.summary().vertical_quantum_m)),
        // How far the plane-fit ground at the centre of the robot's own column may lie from
        // its feet: the ground tolerance plus the rise from the centre to a corner of the
        // column on the steepest slope the robot may stand on.
        level_tolerance_m_(ground_tolerance_m_ +
                           grid_.resolution_m / std::sqrt(2.0) * std::tan(profile.max_tilt_rad)),
        grid_max_(grid_.origin_m + grid_.size.cast<double>() * grid_.resolution_m) {}

  // Speed, acceleration and body height over the whole of piece i (starting at global time
  // `start`), exactly: their maxima by branch and bound, not at samples.
  Status PieceKinematics(std::size_t i, double start) {
    const PiecePolynomials& piece = pieces_[i];
    struct Rule {
      const Polynomial* axes;
      int count;
      double bound;
      double* reported;
      const char* quantity;
      const char* unit;
    };
    const Rule rules[] = {
        {piece.velocity, 2, profile_.max_speed_horizontal_mps, &report_->max_speed_horizontal_mps,
         "horizontal speed", "m/s"},
        {piece.velocity + 2, 1, profile_.max_speed_vertical_mps, &report_->max_speed_vertical_mps,
         "vertical speed", "m/s"},
        {piece.acceleration, 2, profile_.max_accel_horizontal_mps2,
         &report_->max_accel_horizontal_mps2, "horizontal acceleration", "m/s^2"},
        {piece.acceleration + 2, 1, profile_.max_accel_vertical_mps2,
         &report_->max_accel_vertical_mps2, "vertical acceleration", "m/s^2"},
    };
    for (const Rule& rule : rules) {
      const NormMaximum m =
          LargestNorm(rule.axes, rule.count, piece.duration_s, tolerance_ * rule.bound);
      *rule.reported = std::max(*rule.reported, m.value);
      if (!(m.upper <= tolerance_ * rule.bound)) {
        return Violation(start + m.at, Position(start + m.at),
                         Exceeds(rule.quantity, std::max(m.value, m.upper), rule.bound, rule.unit));
      }
    }
    if (!profile_.active_height) return Status::Ok();
    // The commanded body height within the profile's range.
    const PolynomialMaximum high = MaximumAgainst(piece.position[3], piece.duration_s,
                                                  profile_.body_height_max_m + body_slack_m_);
    const PolynomialMaximum low = MaximumAgainst(-piece.position[3], piece.duration_s,
                                                 -(profile_.body_height_min_m - body_slack_m_));
    report_->min_body_height_m = std::min(report_->min_body_height_m, -low.value);
    const bool too_high = !(high.upper <= profile_.body_height_max_m + body_slack_m_);
    const bool too_low = !(-low.upper >= profile_.body_height_min_m - body_slack_m_);
    if (too_high || too_low) {
      const double at = too_high ? high.at : low.at;
      return Violation(start + at, Position(start + at),
                       fmt::format("body height {:.3f} m is outside [{:.3f}, {:.3f}] m",
                                   too_high ? high.value : -low.value, profile_.body_height_min_m,
                                   profile_.body_height_max_m));
    }
    return Status::Ok();
  }

  // The rules at global time t, once they are shown to hold from the last checked instant
  // to t, with instants checked in between where that takes them: where the reference
  // point enters a column, and wherever a stretch is too long for its proof. Piece `piece`
  // (from `piece_start`) holds the stretch after t. Instants must come in increasing order.
  Status Reach(double t, std::size_t piece, double piece_start) {
    if (last_.t >= 0) {
      if (Status s = ReachFromLast(t); !s) return s;
    } else if (Status s = CheckInstant(t); !s) {
      return s;
    }
    last_.piece = piece;
    last_.piece_start = piece_start;
    return Status::Ok();
  }

 private:
  Eigen::Vector3d Position(double t) { return cursor_.Position(t).head<3>(); }

  // Floored cell coordinates of (x, y), as doubles so that no cast can overflow.
  Eigen::Vector2d ColumnOf(const Eigen::Vector3d& p) const {
    return ((p.head<2>() - grid_.origin_m.head<2>()) / grid_.resolution_m).array().floor();
  }

  // Whether the reference point is in last_'s column at time t (by comparisons with the
  // column's offsets: a division and a floor were most of the test).
  bool InLastColumn(double t) {
    const Eigen::Vector2d d = Position(t).head<2>() - grid_.origin_m.head<2>();
    return d.x() >= last_.x.low && d.x() < last_.x.high && d.y() >= last_.y.low &&
           d.y() < last_.y.high;
  }

  // The first instant after last_.t, to kShortestStretchS, at which the reference point is
  // outside last_'s column; it is outside at `to`.
  double LeavesColumn(double to) {
    double lo = last_.t, hi = to;
    for (int halving = 0; halving < 80 && hi - lo > kShortestStretchS; ++halving) {
      const double mid = 0.5 * (lo + hi);
      (InLastColumn(mid) ? lo : hi) = mid;
    }
    return hi;
  }

  Status ReachFromLast(double t) {
    while (last_.t < t) {
      double next = t;
      if (!InLastColumn(next)) next = LeavesColumn(next);
      if (const char* unproven = ProveStretch(next); unproven != nullptr) {
        if (!(next - last_.t > kShortestStretchS)) {
          // Mostly the instant a rule starts to fail: name the violation at the stretch's end.
          if (Status s = CheckInstant(next); !s) return s;
          return Violation(next, Position(next),
                           fmt::format("{} cannot be shown to hold between t = {:.9f} s and "
                                       "this instant",
                                       unproven, last_.t));
        }
        // Check halfway, then prove the two halves.
        if (Status s = ReachFromLast(0.5 * (last_.t + next)); !s) return s;
        continue;
      }
      if (Status s = CheckInstant(next); !s) return s;
    }
    return Status::Ok();
  }

  // Whether every rule holds from last_ to `to` (in last_'s column but possibly `to` itself,
  // where a column is entered), or the first rule it could not show.
  const char* ProveStretch(double to) {
    const PiecePolynomials& piece = pieces_[last_.piece];
    const double a = std::clamp(last_.t - last_.piece_start, 0.0, piece.duration_s);
    const double b = std::clamp(to - last_.piece_start, a, piece.duration_s);
    const Eigen::AlignedBox3d box = piece.PathBox(a, b);
    const Eigen::Vector3d end = Position(to);
    // The column, and so the surface's validity, tilt, ceiling and graph node, stay last_'s.
    const GridGeometry::OffsetRange& x = last_.x;
    const GridGeometry::OffsetRange& y = last_.y;
    const Eigen::Vector2d low = box.min().head<2>() - grid_.origin_m.head<2>();
    const Eigen::Vector2d high = box.max().head<2>() - grid_.origin_m.head<2>();
    if (!(low.x() >= x.low - kColumnEdgeSlackM && high.x() <= x.high + kColumnEdgeSlackM &&
          low.y() >= y.low - kColumnEdgeSlackM && high.y() <= y.high + kColumnEdgeSlackM &&
          box.min().z() >= grid_.origin_m.z() && box.max().z() < grid_max_.z())) {
      return "staying in one column of the grid";
    }
    // The feet stay nearest to the same surface of the column (SampleGround's choice), at
    // its level: the feet's heights over the stretch lie in [box z − reference height].
    const double feet_low = box.min().z() - profile_.reference_height_m;
    const double feet_high = box.max().z() - profile_.reference_height_m;
    const std::span<const ColumnSurface> column = model_.surfaces().Column(
        static_cast<int>(last_.column.x()), static_cast<int>(last_.column.y()));
    const std::size_t k = static_cast<std::size_t>(last_.surface - column.data());
    const double ground = last_.surface->ground_z_m;
    if ((k > 0 && !(feet_low > 0.5 * (column[k - 1].ground_z_m + ground))) ||
        (k + 1 < column.size() && !(feet_high <= 0.5 * (ground + column[k + 1].ground_z_m))) ||
        !(std::abs(last_.surface->plane_center_z_m - feet_low) <= level_tolerance_m_ &&
          std::abs(last_.surface->plane_center_z_m - feet_high) <= level_tolerance_m_)) {
      return "standing on the same ground of the column";
    }
    if (!GroundOffsetHolds(box, feet_low, feet_high)) {
      return "the distance from the reference height above ground";
    }
    // The body under that surface's ceiling.
    const double body_high =
        profile_.active_height ? RangeOn(piece.position[3], a, b).high : profile_.body_height_m;
    if (!(body_high + profile_.headroom_m <= last_.surface->clearance_m + body_slack_m_)) {
      return "the headroom";
    }
    // d at least the bound: its corners' least value in the box, or its slope bound over the
    // path's length from both ends' values (ℓ <= speed bound × duration).
    const TerrainFields::DistanceBounds field = DistanceBoundsIn(box);
    if (!(field.min_m >= config_.min_obstacle_distance_m)) {
      const double length = piece.speed_bound_mps * (b - a);
      const double end_distance = DistanceAt(to, end);
      if (!(0.5 * (last_.distance_m + end_distance - field.max_slope * length) >=
            config_.min_obstacle_distance_m)) {
        return "the obstacle distance";
      }
    }
    if (!KeepOutStretch(piece, a, b, box, end)) return "staying out of keep-out zones";
    return nullptr;
  }

  // Whether the reference point stays within the ground tolerance of h_G over `box`, whose
  // feet's heights lie in [feet_low, feet_high]: on each part of the box between four column
  // centres (a column meets at most two such squares along each axis), h_G's range there
  // (GroundHeightRange) against the range of the feet.
  bool GroundOffsetHolds(const Eigen::AlignedBox3d& box, double feet_low, double feet_high) {
    const Eigen::AlignedBox2d area(box.min().head<2>(), box.max().head<2>());
    const Eigen::Vector2i first = BlendCell(grid_, area.min());
    const Eigen::Vector2i last = BlendCell(grid_, area.max());
    if (((last - first).array() > 1).any()) return false;
    const Eigen::Vector2d slack = Eigen::Vector2d::Constant(kColumnEdgeSlackM);
    for (int cy = first.y(); cy <= last.y(); ++cy) {
      for (int cx = first.x(); cx <= last.x(); ++cx) {
        const GroundChoice* choice = ChoiceFor({cx, cy}, area, feet_low, feet_high);
        if (choice == nullptr) return false;
        const Eigen::AlignedBox2d part = area.intersection(
            Eigen::AlignedBox2d(choice->area.min() - slack, choice->area.max() + slack));
        if (part.isEmpty()) continue;
        double ground_low = 0, ground_high = 0;
        if (!GroundHeightRange(model_, *choice, part, kColumnEdgeSlackM, feet_low, feet_high,
                               &ground_low, &ground_high) ||
            !(feet_high - ground_low <= ground_tolerance_m_ &&
              ground_high - feet_low <= ground_tolerance_m_)) {
          return false;
        }
      }
    }
    return true;
  }

  // SampleGround's choice of corners for the square between four column centres whose
  // lower-left one is `cell`: the last one made there while it stands for the feet's band
  // [feet_low, feet_high], else made at the point of `area` nearest to the square's middle and
  // the band's middle (one slot per parity of the cell, so the up to four squares of one box
  // never evict each other); null where none is made (outside the grid).
  const GroundChoice* ChoiceFor(const Eigen::Vector2i& cell, const Eigen::AlignedBox2d& area,
                                double feet_low, double feet_high) {
    GroundChoice& choice = proof_choices_[(cell.x() & 1) + 2 * (cell.y() & 1)];
    if (choice.cell == cell && feet_low > choice.low_m && feet_high < choice.high_m) {
      return &choice;
    }
    const double r = grid_.resolution_m;
    const Eigen::Array2d square_low =
        grid_.origin_m.head<2>().array() + (cell.cast<double>().array() + 0.5) * r;
    // Inside the square by a hair more than the choice's own margin (1 nm).
    const Eigen::Array2d low = area.min().array().max(square_low + 1e-8);
    const Eigen::Array2d high = area.max().array().min(square_low + r - 1e-8);
    const Eigen::Array2d at = (square_low + 0.5 * r).max(low).min(high);
    GroundSample scratch;
    const double feet = 0.5 * (feet_low + feet_high);
    SampleGround(model_, {at.x(), at.y(), feet + profile_.reference_height_m},
                 profile_.reference_height_m, 0, &scratch, &choice);
    return choice.cell == cell ? &choice : nullptr;
  }

  // The distance field's bounds in `box`, from the last box's when both read the same blocks
  // (consecutive stretches, 2 cm long, mostly do).
  TerrainFields::DistanceBounds DistanceBoundsIn(const Eigen::AlignedBox3d& box) {
    const TerrainFields& fields = model_.fields();
    const std::int64_t low = fields.BlockKey(box.min()), high = fields.BlockKey(box.max());
    if (low != bounds_of_.low || high != bounds_of_.high) {
      bounds_of_ = {low, high, fields.DistanceBoundsIn(box)};
    }
    return bounds_of_.bounds;
  }

  // d at time t (position p), kept for the check of the instant t that follows a stretch's
  // proof.
  double DistanceAt(double t, const Eigen::Vector3d& p) {
    if (t != distance_at_.t) distance_at_ = {t, model_.Distance(p)};
    return distance_at_.value;
  }

  // Whether the robot stays out of every keep-out zone from last_ to local time b: for each
  // zone, its height range clear of the zone's for every reference height of the box, or its
  // footprint clear of the polygon by half the path's length (the footprint's penetration is
  // 1-Lipschitz in x, y).
  bool KeepOutStretch(const PiecePolynomials& piece, double a, double b,
                      const Eigen::AlignedBox3d& box, const Eigen::Vector3d& end) const {
    const double half_length = 0.5 * piece.speed_bound_mps * (b - a);
    const double radius = profile_.footprint_radius_m;
    for (const KeepOutZone& zone : keep_out_) {
      if ((box.min().head<2>().array() > zone.bounds_m.max().head<2>().array() + radius).any() ||
          (box.max().head<2>().array() < zone.bounds_m.min().head<2>().array() - radius).any()) {
        continue;
      }
      // Below the zone even at the box's highest reference height (the overlap, at most 0,
      // still rises with z), or above it even at the lowest (it falls).
      double rise = 0;
      if (KeepOutVerticalOverlap(zone.prism, profile_, box.max().z(), &rise) <= 0 && rise > 0) {
        continue;
      }
      if (KeepOutVerticalOverlap(zone.prism, profile_, box.min().z(), &rise) <= 0 && rise < 0) {
        continue;
      }
      if (0.5 * (KeepOutPenetration(zone.prism, profile_, last_.position) +
                 KeepOutPenetration(zone.prism, profile_, end)) +
              half_length <=
          0) {
        continue;
      }
      return false;
    }
    return true;
  }

  // Every rule of one instant, in order; the first violation. Records the instant in last_.
  Status CheckInstant(double t) {
    const Eigen::Vector3d p = Position(t);
    ++report_->samples;
    if (Status s = InsideGrid(t, p); !s) return s;
    GroundSample ground;
    const Eigen::Vector3i cell = grid_.CellOf(p);
    if (Status s = GroundOfOwnColumn(t, p, cell, &ground); !s) return s;
    const ColumnSurface& surface = *ground.surface;
    if (Status s = GroundAtRobotsLevel(t, p, surface); !s) return s;
    if (Status s = ValidGround(t, p, surface); !s) return s;
    if (Status s = Tilt(t, p, surface); !s) return s;
    if (Status s = GroundOffset(t, p, ground); !s) return s;
    double distance = 0;
    if (Status s = ObstacleDistance(t, p, &distance); !s) return s;
    const double body = profile_.active_height ? cursor_.Position(t)(3) : profile_.body_height_m;
    if (Status s = Headroom(t, p, surface, body); !s) return s;
    if (Status s = GraphNode(t, p, cell, ground.surface); !s) return s;
    if (Status s = KeepOut(t, p); !s) return s;
    if (const Eigen::Vector2d column = ColumnOf(p); column != last_.column || last_.t < 0) {
      last_.column = column;
      last_.x = grid_.OffsetsOfIndex(column.x());
      last_.y = grid_.OffsetsOfIndex(column.y());
    }
    last_.t = t;
    last_.surface = ground.surface;
    last_.distance_m = distance;
    last_.position = p;
    return Status::Ok();
  }

  Status InsideGrid(double t, const Eigen::Vector3d& p) const {
    if (!((p.array() >= grid_.origin_m.array()).all() && (p.array() < grid_max_.array()).all())) {
      return Violation(t, p, "no ground: the reference point is outside the map's grid");
    }
    return Status::Ok();
  }

  // The surface the robot stands on is the one of its own column nearest to its feet
  // (SampleGround), never another level of that column (the deck above a passage too low for
  // it).
  Status GroundOfOwnColumn(double t, const Eigen::Vector3d& p, const Eigen::Vector3i& cell,
                           GroundSample* ground) {
    if (!SampleGround(model_, p, profile_.reference_height_m, 0, ground, &ground_choice_) ||
        SurfaceOfColumn(model_, cell, ground->surface) == nullptr) {
      return Violation(t, p, "no ground in the column below the reference point");
    }
    return Status::Ok();
  }

  // The column's nearest surface may be another level: the top of a post, a table leg or a
  // wall the reference point is inside of, while the smoothed ground comes from the columns
  // around.
  Status GroundAtRobotsLevel(double t, const Eigen::Vector3d& p,
                             const ColumnSurface& surface) const {
    const double feet_m = p.z() - profile_.reference_height_m;
    if (!(std::abs(surface.plane_center_z_m - feet_m) <= level_tolerance_m_)) {
      return Violation(t, p,
                       fmt::format("no ground in the column below at the robot's level: its "
                                   "nearest surface is {:.3f} m from the reference point's "
                                   "ground height {:.3f} m (more than {:.3f} m; a post, a "
                                   "table leg or a wall?)",
                                   surface.plane_center_z_m - feet_m, feet_m, level_tolerance_m_));
    }
    return Status::Ok();
  }

  static Status ValidGround(double t, const Eigen::Vector3d& p, const ColumnSurface& surface) {
    if (!surface.valid) {
      return Violation(t, p,
                       "the ground below is not valid ground (the Valid Ground Filter found "
                       "an obstacle, an overhang or a steep rise within its radius)");
    }
    return Status::Ok();
  }

  Status Tilt(double t, const Eigen::Vector3d& p, const ColumnSurface& surface) {
    const double tilt = surface.tilt_rad;
    report_->max_tilt_rad = std::max(report_->max_tilt_rad, tilt);
    if (!(tilt <= profile_.max_tilt_rad)) {
      return Violation(
          t, p, Exceeds("ground tilt", tilt / kDegree, profile_.max_tilt_rad / kDegree, "deg"));
    }
    return Status::Ok();
  }

  // z within the ground tolerance of the smoothed ground + the reference height.
  Status GroundOffset(double t, const Eigen::Vector3d& p, const GroundSample& ground) {
    const double offset = p.z() - ground.height_m - profile_.reference_height_m;
    report_->max_ground_offset_m = std::max(report_->max_ground_offset_m, std::abs(offset));
    if (!(std::abs(offset) <= ground_tolerance_m_)) {
      return Violation(t, p,
                       Exceeds("distance from the reference height above ground", std::abs(offset),
                               ground_tolerance_m_, "m"));
    }
    return Status::Ok();
  }

  Status ObstacleDistance(double t, const Eigen::Vector3d& p, double* distance_out) {
    const double distance = t == distance_at_.t ? distance_at_.value : model_.Distance(p);
    *distance_out = distance;
    report_->min_obstacle_distance_m = std::min(report_->min_obstacle_distance_m, distance);
    if (!(distance >= config_.min_obstacle_distance_m)) {
      return Violation(t, p,
                       fmt::format("obstacle distance {:.3f} m is below {:.3f} m", distance,
                                   config_.min_obstacle_distance_m));
    }
    return Status::Ok();
  }

  // The body under the ceiling with the profile's headroom above it.
  Status Headroom(double t, const Eigen::Vector3d& p, const ColumnSurface& surface, double body) {
    const double clearance = surface.clearance_m;
    report_->min_body_height_m = std::min(report_->min_body_height_m, body);
    report_->min_headroom_m = std::min(report_->min_headroom_m, clearance - body);
    if (!(body + profile_.headroom_m <= clearance + body_slack_m_)) {
      return Violation(t, p,
                       fmt::format("headroom {:.3f} m between the body (height {:.3f} m) and "
                                   "the ceiling ({:.3f} m above ground) is below the profile's "
                                   "headroom_m {:.3f} m",
                                   clearance - body, body, clearance, profile_.headroom_m));
    }
    return Status::Ok();
  }

  // The graph the path was searched on must hold this surface too (it does when it was built
  // from profile.Traversability(); another robot's graph may not).
  Status GraphNode(double t, const Eigen::Vector3d& p, const Eigen::Vector3i& cell,
                   const ColumnSurface* surface) const {
    if (!HasNodeOn(graph_, cell, surface)) {
      return Violation(t, p,
                       "the ground below is not a node of the traversability graph (a graph "
                       "built for other traversability parameters than this profile's?)");
    }
    return Status::Ok();
  }

  Status KeepOut(double t, const Eigen::Vector3d& p) const {
    if (const int zone = FirstViolatedKeepOut(keep_out_, profile_, p); zone >= 0) {
      return Violation(t, p,
                       fmt::format("inside {}: the footprint (radius {:.3f} m) reaches {:.3f} m "
                                   "into its polygon within its height range",
                                   keep_out_[zone].name, profile_.footprint_radius_m,
                                   KeepOutPenetration(keep_out_[zone].prism, profile_, p)));
    }
    return Status::Ok();
  }

  const SurfaceGraph& graph_;
  const TerrainModel& model_;
  const GridGeometry& grid_;
  const RobotProfile& profile_;
  const VerifierConfig& config_;
  const std::vector<PiecePolynomials>& pieces_;
  TrajectoryCursor cursor_;
  std::span<const KeepOutZone> keep_out_;
  VerificationReport* report_;
  const double tolerance_;
  const double body_slack_m_;
  const double ground_tolerance_m_;
  const double level_tolerance_m_;
  const Eigen::Vector3d grid_max_;
  // Consecutive samples, 2 cm apart, mostly stand on the same column corners: SampleGround
  // reuses their choice where it holds (the same answers, fewer column scans).
  GroundChoice ground_choice_;
  // The stretches' choices, by the parity of their cell (ChoiceFor).
  GroundChoice proof_choices_[4];
  CheckedInstant last_;
  struct {
    std::int64_t low = -1, high = -1;  // The BlockKeys of a box's corners.
    TerrainFields::DistanceBounds bounds;
  } bounds_of_;
  struct {
    double t = -1;
    double value = 0;
  } distance_at_;
};

// The trajectory's shape before anything is sampled: the profile's dimension, pieces with
// finite coefficients and finite positive durations.
Status CheckShape(const Trajectory& trajectory, const RobotProfile& profile) {
  const int dimension = profile.active_height ? 4 : 3;
  if (trajectory.dimension != dimension) {
    return Error{ErrorCode::kInvalidInput,
                 fmt::format("trajectory has dimension {} but profile '{}' needs {} (x, y, z{})",
                             trajectory.dimension, profile.name, dimension,
                             profile.active_height ? ", body height" : "")};
  }
  if (trajectory.pieces.empty()) {
    return Error{ErrorCode::kOptimizationFailed, "trajectory verification failed: no pieces"};
  }
  for (std::size_t i = 0; i < trajectory.pieces.size(); ++i) {
    const TrajectoryPiece& piece = trajectory.pieces[i];
    if (piece.coefficients.cols() != dimension) {
      return Error{ErrorCode::kInvalidInput,
                   fmt::format("trajectory piece {} has {} axes, the trajectory {}", i,
                               piece.coefficients.cols(), dimension)};
    }
    // Everything below evaluates these; a NaN would also make the step count undefined.
    if (!(std::isfinite(piece.duration_s) && piece.duration_s > 0) ||
        !piece.coefficients.allFinite()) {
      return Error{ErrorCode::kOptimizationFailed,
                   fmt::format("trajectory verification failed: piece {} has duration {:g} s "
                               "and {} coefficients; both must be finite, the duration > 0",
                               i, piece.duration_s,
                               piece.coefficients.allFinite() ? "finite" : "non-finite")};
    }
  }
  return Status::Ok();
}

}  // namespace

Status VerifyTrajectory(const SurfaceGraph& graph, const RobotProfile& profile,
                        const Trajectory& trajectory, const VerifierConfig& config,
                        VerificationReport* report, std::span<const KeepOutZone> keep_out,
                        const Traffic* traffic) {
  if (Status s = config.Validate(); !s) return s;
  if (Status s = profile.Validate(); !s) return s;
  if (traffic != nullptr) {
    if (Status s = traffic->rule.Validate("traffic.rule"); !s) return s;
    if (Status s = traffic->body.Validate("traffic.body"); !s) return s;
  }
  *report = VerificationReport{};
  report->min_obstacle_distance_m = std::numeric_limits<double>::infinity();
  report->min_body_height_m = std::numeric_limits<double>::infinity();
  report->min_headroom_m = std::numeric_limits<double>::infinity();
  if (Status s = CheckShape(trajectory, profile); !s) return s;
  std::vector<PiecePolynomials> pieces;
  pieces.reserve(trajectory.pieces.size());
  double sample_count = 0;
  for (const TrajectoryPiece& piece : trajectory.pieces) {
    pieces.emplace_back(piece, trajectory.dimension);
    sample_count += pieces.back().speed_bound_mps * piece.duration_s / config.max_sample_spacing_m;
  }
  if (!(sample_count <= kMaxSamples)) {
    return Error{ErrorCode::kOptimizationFailed,
                 fmt::format("trajectory verification failed: {:.3g} samples {:.3g} m apart are "
                             "too many (at most {:.0f}); the trajectory is too long or too fast",
                             sample_count, config.max_sample_spacing_m, kMaxSamples)};
  }
  StateChecker checker(graph, profile, config, trajectory, pieces, keep_out, report);
  double piece_start = 0;
  for (std::size_t i = 0; i < trajectory.pieces.size(); ++i) {
    const double piece_duration = trajectory.pieces[i].duration_s;
    if (Status s = checker.PieceKinematics(i, piece_start); !s) return s;
    // Samples no farther apart than the spacing along the path: the speed bound is exact.
    const int steps =
        std::max(1, static_cast<int>(std::ceil(piece_duration * pieces[i].speed_bound_mps /
                                               config.max_sample_spacing_m)));
    // Each piece's samples include its start; the last piece also its end.
    const int last = i + 1 == trajectory.pieces.size() ? steps : steps - 1;
    for (int k = 0; k <= last; ++k) {
      if (Status s = checker.Reach(piece_start + piece_duration * k / steps, i, piece_start); !s) {
        return s;
      }
    }
    piece_start += piece_duration;
  }
  if (traffic != nullptr) {
    return CheckSeparation(traffic->MotionOf(trajectory), traffic->others, traffic->rule);
  }
  return Status::Ok();
}

double MeanCurvature(const Trajectory& trajectory, int samples) {
  if (trajectory.pieces.empty() || samples < 1) return 0;
  const double duration = trajectory.TotalDuration();
  double sum = 0;
  int counted = 0;
  TrajectoryCursor cursor(trajectory);
  for (int k = 0; k < samples; ++k) {
    const double t = duration * (k + 0.5) / samples;
    const Eigen::Vector3d v = cursor.Velocity(t).head<3>();
    const Eigen::Vector3d a = cursor.Acceleration(t).head<3>();
    const double speed = v.norm();
    if (speed < 0.01) continue;
    sum += v.cross(a).norm() / (speed * speed * speed);
    ++counted;
  }
  return counted > 0 ? sum / counted : 0;
}

double PathLength(const Trajectory& trajectory) {
  double length = 0;
  for (std::size_t i = 0; i < trajectory.pieces.size(); ++i) {
    const double duration = trajectory.pieces[i].duration_s;
    // Steps small enough that the chord error is far below a centimetre.
    const int steps = std::max(8, static_cast<int>(std::ceil(duration * 100)));
    Eigen::Vector3d previous = trajectory.EvaluatePiece(i, 0, 0).head<3>();
    for (int k = 1; k <= steps; ++k) {
      const Eigen::Vector3d next = trajectory.EvaluatePiece(i, duration * k / steps, 0).head<3>();
      length += (next - previous).norm();
      previous = next;
    }
  }
  return length;
}

}  // namespace strata
