#include "rpc/recent_plans.hpp"

#include <algorithm>
#include <string>

#include "common/service_error.hpp"

namespace strata::server {

RecentPlans::RecentPlans(std::size_t max_plans, std::size_t max_bytes)
    : max_plans_(std::max<std::size_t>(1, max_plans)), max_bytes_(max_bytes) {}

void RecentPlans::Record(v1::RecentPlan plan) {
  // The message is built and measured outside the lock; only the bookkeeping is inside.
  if (plan.ByteSizeLong() > max_bytes_ / 8) {
    plan.mutable_request()->clear_keep_out();
    if (plan.has_response()) {
      v1::PlanResponse* response = plan.mutable_response();
      response->clear_trajectory();
      response->clear_samples();
      response->clear_search_path_m();
    }
    plan.set_trimmed(true);
    if (plan.ByteSizeLong() > max_bytes_ / 8) {
      // Still too large: only huge strings in the request (a profile's name, a map id) can
      // make it so. Keep the map id, cut.
      const std::string map_id = BoundedText(plan.request().map_id(), 64);
      plan.clear_request();
      plan.mutable_request()->set_map_id(map_id);
    }
  }
  const std::size_t size = plan.ByteSizeLong();
  std::lock_guard lock(mutex_);
  while (!plans_.empty() && (plans_.size() >= max_plans_ || bytes_ + size > max_bytes_)) {
    bytes_ -= plans_.front().ByteSizeLong();
    plans_.pop_front();
  }
  bytes_ += size;
  plans_.push_back(std::move(plan));
}

void RecentPlans::List(std::size_t max_plans, v1::ListRecentPlansResponse* response) const {
  std::lock_guard lock(mutex_);
  const std::size_t count = max_plans == 0 ? plans_.size() : std::min(max_plans, plans_.size());
  for (std::size_t i = 0; i < count; ++i) *response->add_plans() = plans_[plans_.size() - 1 - i];
}

std::size_t RecentPlans::bytes() const {
  std::lock_guard lock(mutex_);
  return bytes_;
}

}  // namespace strata::server
