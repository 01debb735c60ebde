#pragma once
/// The plans a server answered most recently (PlannerService.ListRecentPlans, the web viewer's
/// list): a ring of RecentPlan messages in memory, bounded in count and in bytes, so that a
/// flood of large requests can never make it grow.
#include <cstddef>
#include <deque>
#include <mutex>

#include "strata/v1/planner_service.pb.h"

namespace strata::server {

/// Plans kept at most [-].
inline constexpr std::size_t kRecentPlansKept = 32;
/// Bytes the kept plans may take, in protobuf's encoding [bytes].
inline constexpr std::size_t kRecentPlansMaxBytes = std::size_t{4} << 20;

class RecentPlans {
 public:
  /// Keeps at most `max_plans` >= 1 plans and `max_bytes` bytes (ByteSizeLong of each).
  explicit RecentPlans(std::size_t max_plans = kRecentPlansKept,
                       std::size_t max_bytes = kRecentPlansMaxBytes);

  /// Adds `plan`, dropping the oldest plans until it fits. A plan larger than an eighth of
  /// max_bytes is kept trimmed (RecentPlan.trimmed): without its request's keep-out zones and
  /// its response's trajectory, samples and search path, and, should that not suffice, with
  /// nothing of its request but the map id. Thread-safe.
  void Record(v1::RecentPlan plan);

  /// The newest `max_plans` (every plan kept for 0), newest first. Thread-safe.
  void List(std::size_t max_plans, v1::ListRecentPlansResponse* response) const;

  /// Bytes held now (the sum the bound applies to).
  std::size_t bytes() const;

 private:
  const std::size_t max_plans_;
  const std::size_t max_bytes_;
  mutable std::mutex mutex_;
  std::deque<v1::RecentPlan> plans_;  // Oldest first.
  std::size_t bytes_ = 0;
};

}  // namespace strata::server
