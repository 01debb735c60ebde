#pragma once
/// Progress and cancellation inside terrain assessment's parallel loops. The caller's
/// callbacks (AssessmentControl) are never called from two threads at once: whichever worker
/// takes the lock reports, the others carry on. A stop request is remembered in a flag that
/// every worker reads between its units of work, so an OpenMP loop (which cannot break) drains
/// in at most one unit per thread.

#include <atomic>
#include <cstdint>
#include <mutex>

#include "strata/assessment/assessment_control.hpp"

namespace strata::internal {

class ProgressReporter {
 public:
  /// `control` may be null (nothing reported, never stopped); it must outlive the reporter.
  explicit ProgressReporter(const AssessmentControl* control) : control_(control) {}

  /// Starts `stage`, whose work is `total_units` units (columns, tiles...). Not thread-safe:
  /// call between parallel loops.
  void BeginStage(AssessmentStage stage, std::int64_t total_units) {
    stage_ = stage;
    total_ = total_units > 0 ? total_units : 1;
    done_.store(0, std::memory_order_relaxed);
    next_report_ = 0;
    Report(0.0);
  }

  /// Records `units` more done. Thread-safe. Returns false once the assessment should stop.
  bool Advance(std::int64_t units) {
    const std::int64_t done = done_.fetch_add(units, std::memory_order_relaxed) + units;
    if (control_ != nullptr && lock_.try_lock()) {
      const double fraction = static_cast<double>(done) / static_cast<double>(total_);
      if (fraction >= next_report_) {
        next_report_ = fraction + kReportStep;
        ReportLocked(fraction);
      }
      lock_.unlock();
    }
    return !stopped();
  }

  /// True once should_stop returned true; later calls of should_stop are skipped.
  bool stopped() const { return stopped_.load(std::memory_order_relaxed); }

 private:
  static constexpr double kReportStep = 0.01;

  void Report(double fraction) {
    if (control_ == nullptr) return;
    std::lock_guard lock(lock_);
    ReportLocked(fraction);
  }
  void ReportLocked(double fraction) {
    if (control_->on_progress) control_->on_progress(stage_, fraction < 1 ? fraction : 1.0);
    if (!stopped() && control_->should_stop && control_->should_stop()) {
      stopped_.store(true, std::memory_order_relaxed);
    }
  }

  const AssessmentControl* control_;
  AssessmentStage stage_ = AssessmentStage::kSorting;
  std::int64_t total_ = 1;
  std::atomic<std::int64_t> done_{0};
  std::atomic<bool> stopped_{false};
  std::mutex lock_;
  double next_report_ = 0;  // Guarded by lock_.
};

}  // namespace strata::internal
