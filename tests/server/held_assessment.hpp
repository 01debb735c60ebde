#pragma once
// A registry build hook that holds the assessment in one step until the test lets it go, so a
// test can look at (or delete) a map being made whatever the machine's speed.
#include <condition_variable>
#include <mutex>
#include <optional>
#include <string>

#include "maps/map_registry.hpp"

namespace strata::server::testing {

class HeldAssessment {
 public:
  explicit HeldAssessment(AssessmentStage step) : step_(step) {}

  /// For RegistryOptions::build: BuildMapHere, held at the first report of the step.
  MapBuilder Builder() {
    return [this](MapBuildJob job, const BuildMonitor& monitor) -> Result<BuiltMap> {
      BuildMonitor holding = monitor;
      holding.on_progress = [this, report = monitor.on_progress](AssessmentStage step,
                                                                 double fraction) {
        if (report) report(step, fraction);
        std::unique_lock lock(mutex_);
        const std::string name = AssessmentStageName(step);
        if (steps_.find(name) == std::string::npos) steps_ += name + " ";
        if (step != step_) return;
        held_ = true;
        changed_.notify_all();
        changed_.wait(lock, [&] { return released_; });
      };
      Expected<BuiltMap> built = BuildMapHere(std::move(job), holding);
      std::lock_guard lock(mutex_);
      ended_ = true;
      if (!built) code_ = built.error().code;
      changed_.notify_all();
      if (!built) return ServiceError::FromPlanner(built.error());
      return std::move(built).value();
    };
  }

  /// Blocks until the assessment is held in the step.
  void WaitHeld() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return held_; });
  }
  /// Lets the assessment go on.
  void Release() {
    std::lock_guard lock(mutex_);
    released_ = true;
    changed_.notify_all();
  }
  /// Blocks until the build has ended: empty when it made the map, else its error code.
  std::optional<ErrorCode> WaitEnded() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return ended_; });
    return code_;
  }
  /// The steps reported so far, once each, in order.
  std::string Steps() {
    std::lock_guard lock(mutex_);
    return steps_;
  }

 private:
  const AssessmentStage step_;
  std::mutex mutex_;
  std::condition_variable changed_;
  bool held_ = false, released_ = false, ended_ = false;
  std::string steps_;
  std::optional<ErrorCode> code_;
};

}  // namespace strata::server::testing
