#pragma once
/// Whether two robots' motions ever come too close, decided over continuous time.
///
/// Two bodies conflict at time t when their reference points are closer horizontally than
/// the sum of their radii plus a separation (the larger of what each motion asks and the
/// check's rule), while their vertical extents (ground to top of body) overlap. A robot on a deck
/// and one under it, or robots on two floors of a garage, never conflict.
///
/// Exact, not sampled: over each stretch of time on which both motions follow one polynomial
/// piece (or stand parked), the squared horizontal distance is a polynomial of degree 10 and
/// the two vertical overlaps are polynomials of degree 5. Their Bernstein coefficients bound
/// each polynomial's range over the stretch; stretches whose bounds rule a conflict out are
/// dropped, the others halved (de Casteljau) and examined earliest first. The answer:
/// - never misses: any moment of conflict (deeper than floating-point rounding) is reported,
///   at that moment or earlier;
/// - never raises a false alarm beyond the tolerance: at the reported moment the bodies are
///   closer than the limit plus distance_tolerance_m horizontally while their vertical
///   extents overlap or miss by less than vertical_tolerance_m.
#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "strata/fleet/fleet_motion.hpp"
#include "strata/status.hpp"

namespace strata {

struct SeparationRule {
  /// Free horizontal distance kept between two bodies [m], >= 0, finite, at least: they
  /// conflict when their reference points are closer than the sum of their radii plus this, or
  /// plus a motion's own FleetMotion::separation_m where that is larger.
  double separation_m = 0.1;
  /// How far beyond the limit a reported conflict may be [m], > 0 (see the file comment).
  double distance_tolerance_m = 1e-3;
  /// How far apart vertically two bodies of a reported conflict may be [m], > 0.
  double vertical_tolerance_m = 1e-3;

  /// kInvalidInput blaming the first bad field, `path`.<field>.
  Status Validate(std::string_view path) const;
};

/// The free distance [m] two motions keep under `rule`: the largest of the rule's and the two
/// motions' own separations.
double PairSeparationM(const SeparationRule& rule, const FleetMotion& a, const FleetMotion& b);
/// The free distance [m] a robot planned under `rule` keeps from `other`: the pair's, for a
/// robot that asks the rule's own separation (as Traffic::MotionOf sets it).
double PairSeparationM(const SeparationRule& rule, const FleetMotion& other);

/// The earliest moment (within the rule's tolerance) at which two motions conflict.
struct MotionConflict {
  std::int64_t time_ns = 0;          ///< Absolute time [ns].
  Eigen::Vector3d point_a;           ///< First motion's reference point then [m].
  Eigen::Vector3d point_b;           ///< Second motion's reference point then [m].
  double horizontal_distance_m = 0;  ///< Between the two reference points [m].
  double limit_m = 0;                ///< Sum of the radii plus the pair's separation [m].
};

namespace fleet_internal {
struct BoundedPiece;
}  // namespace fleet_internal

/// A motion made ready to be checked against many others: its pieces (and its parked time)
/// with the bounds that rule pairs out. Making them is most of a check that finds nothing,
/// so a motion checked against many (a plan against the traffic, the traffic against each
/// departure tried) is prepared once. Refers to `motion`, which must outlive it.
class PreparedMotion {
 public:
  explicit PreparedMotion(const FleetMotion& motion);
  ~PreparedMotion();
  PreparedMotion(PreparedMotion&&) noexcept;
  PreparedMotion& operator=(PreparedMotion&&) noexcept;
  PreparedMotion(const PreparedMotion&) = delete;
  PreparedMotion& operator=(const PreparedMotion&) = delete;

  const FleetMotion& motion() const { return *motion_; }
  const std::vector<fleet_internal::BoundedPiece>& pieces() const { return pieces_; }

 private:
  const FleetMotion* motion_;
  std::vector<fleet_internal::BoundedPiece> pieces_;  // In time order.
};

/// The first conflict between `a` and `b` over the time both exist, if any. Both motions must
/// be valid (FleetMotion::Validate) and the rule too; the cost is linear in the number of
/// pieces of the two, plus a subdivision where the bodies come within reach of each other.
std::optional<MotionConflict> FirstConflict(const FleetMotion& a, const FleetMotion& b,
                                            const SeparationRule& rule);
/// The same, of motions prepared already.
std::optional<MotionConflict> FirstConflict(const PreparedMotion& a, const PreparedMotion& b,
                                            const SeparationRule& rule);

}  // namespace strata
