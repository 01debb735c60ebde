#pragma once
/// The other robots' committed motions a robot's trajectory must keep apart from, and the
/// check that it does: exact over continuous time (motion_conflict.hpp), earliest conflict
/// first, named by the robot in the way.
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "strata/fleet/fleet_motion.hpp"
#include "strata/fleet/motion_conflict.hpp"
#include "strata/status.hpp"

namespace strata {

/// Another robot's committed motion (a reservation on the schedule).
struct ReservedMotion {
  std::string robot_id;  ///< Names the robot in messages.
  FleetMotion motion;
};

/// What a robot's trajectory is checked against: when it runs, the body it moves, and the
/// others' motions. The robot's own earlier reservation is not among `others` (a new plan
/// replaces it from its departure on).
struct Traffic {
  std::int64_t departure_ns = 0;  ///< Absolute time of the trajectory's t = 0 [ns].
  /// Until when the robot then stays parked at the trajectory's end [ns] (its lease); a
  /// departure plus the trajectory's duration, if later, takes its place.
  std::int64_t parked_until_ns = 0;
  FleetBody body;
  SeparationRule rule;
  std::span<const ReservedMotion> others;

  /// `trajectory` placed at the departure, with this body, parked until parked_until_ns (or
  /// the arrival, if later).
  FleetMotion MotionOf(const Trajectory& trajectory) const;
};

/// The earliest conflict between `own` and any of `others`.
struct TrafficConflict {
  std::size_t other = 0;  ///< Index into `others`.
  MotionConflict conflict;
};

/// The earliest conflict of `own` with `others` (ties: the first in `others`), if any.
std::optional<TrafficConflict> FirstTrafficConflict(const FleetMotion& own,
                                                    std::span<const ReservedMotion> others,
                                                    const SeparationRule& rule);
/// The same, of `own` against others prepared already (PrepareOthers), in their order.
std::optional<TrafficConflict> FirstTrafficConflict(const FleetMotion& own,
                                                    std::span<const PreparedMotion> others,
                                                    const SeparationRule& rule);
/// `others`' motions prepared for FirstTrafficConflict; they refer to `others`.
std::vector<PreparedMotion> PrepareOthers(std::span<const ReservedMotion> others);

/// Error::details of a reservation conflict with robot `robot_id`: "robot_id", "time_ns",
/// and "x_m", "y_m", "z_m", the reference point of the robot being planned then.
std::map<std::string, std::string> ConflictDetails(const std::string& robot_id,
                                                   const MotionConflict& conflict);

/// Ok when `own` conflicts with none of `others`; otherwise kReservationConflict naming the
/// first conflict: the robot in the way, when (absolute and since `own` starts), where both
/// reference points are, their distance and the limit; Error::details as ConflictDetails.
Status CheckSeparation(const FleetMotion& own, std::span<const ReservedMotion> others,
                       const SeparationRule& rule);

}  // namespace strata
