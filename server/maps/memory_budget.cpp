#include "maps/memory_budget.hpp"

#include <algorithm>
#include <fstream>
#include <limits>
#include <utility>

#include <fmt/format.h>

namespace strata::server {
namespace {

constexpr std::uint64_t kNoLimit = std::numeric_limits<std::uint64_t>::max();

std::uint64_t SaturatingAdd(std::uint64_t a, std::uint64_t b) {
  return a > kNoLimit - b ? kNoLimit : a + b;
}

std::size_t Index(MemoryBudget::Use use) { return static_cast<std::size_t>(use); }

// The first number in the file, or kNoLimit when there is none ("max", no file).
std::uint64_t NumberIn(const char* path) {
  std::ifstream file(path);
  std::uint64_t value = 0;
  return file >> value ? value : kNoLimit;
}

// MemTotal of /proc/meminfo [bytes].
std::uint64_t MachineMemory() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  while (meminfo >> key) {
    if (key == "MemTotal:") {
      std::uint64_t kib = 0;
      meminfo >> kib;
      return kib * 1024;
    }
    meminfo.ignore(1 << 16, '\n');
  }
  return kNoLimit;
}

}  // namespace

std::string MebibytesText(std::uint64_t bytes) {
  return fmt::format("{:.1f} MiB", static_cast<double>(bytes) / (1 << 20));
}

std::uint64_t AutomaticMemoryLimit() {
  const std::uint64_t available =
      std::min({NumberIn("/sys/fs/cgroup/memory.max"),                    // cgroup v2
                NumberIn("/sys/fs/cgroup/memory/memory.limit_in_bytes"),  // cgroup v1
                MachineMemory()});
  return available == kNoLimit ? 0 : available / 5 * 4;
}

MemoryBudget::Reservation::Reservation(Reservation&& other) noexcept
    : budget_(std::exchange(other.budget_, nullptr)),
      use_(other.use_),
      bytes_(std::exchange(other.bytes_, 0)) {}

MemoryBudget::Reservation& MemoryBudget::Reservation::operator=(Reservation&& other) noexcept {
  if (this != &other) {
    Release();
    budget_ = std::exchange(other.budget_, nullptr);
    use_ = other.use_;
    bytes_ = std::exchange(other.bytes_, 0);
  }
  return *this;
}

ServiceStatus MemoryBudget::Reservation::Grow(std::uint64_t bytes, std::string_view what) {
  if (budget_ == nullptr) return OkStatus();
  Use use = use_;
  if (ServiceStatus admitted = budget_->Admit(bytes, what, &use); !admitted.ok()) return admitted;
  bytes_ += bytes;
  return OkStatus();
}

void MemoryBudget::Reservation::Release() {
  if (budget_ != nullptr && bytes_ > 0) budget_->Unreserve(use_, bytes_);
  bytes_ = 0;
}

void MemoryBudget::WatchMaps(std::function<std::uint64_t()> held_bytes,
                             std::function<void(std::uint64_t)> trim) {
  held_bytes_ = std::move(held_bytes);
  trim_ = std::move(trim);
}

Result<MemoryBudget::Reservation> MemoryBudget::Reserve(Use use, std::uint64_t bytes,
                                                        std::string_view what) {
  if (ServiceStatus admitted = Admit(bytes, what, &use); !admitted.ok()) {
    return std::move(admitted).error();
  }
  return Reservation(this, use, bytes);
}

ServiceStatus MemoryBudget::AdmitMap(std::uint64_t bytes, std::string_view what) {
  return Admit(bytes, what, nullptr);
}

ServiceStatus MemoryBudget::Admit(std::uint64_t bytes, std::string_view what, Use* use) {
  std::uint64_t maps = map_bytes();
  for (int attempt = 0;; ++attempt) {
    std::uint64_t target = 0;  // What the maps must shrink to for `bytes` to fit.
    {
      std::lock_guard lock(mutex_);
      if (FitsLocked(bytes, maps)) {
        if (use != nullptr) reserved_[Index(*use)] += bytes;
        return OkStatus();
      }
      const std::uint64_t others = SaturatingAdd(SaturatingAdd(reserved_[0], reserved_[1]), bytes);
      if (attempt == 1 || !trim_ || others > limit_) return Exhausted(bytes, what, maps);
      target = limit_ - others;
    }
    // Outside the lock: trimming takes the cache's lock, which may ask MapAllowance().
    trim_(target);
    maps = map_bytes();
  }
}

bool MemoryBudget::FitsLocked(std::uint64_t bytes, std::uint64_t maps) const {
  if (limit_ == 0) return true;
  return SaturatingAdd(SaturatingAdd(SaturatingAdd(reserved_[0], reserved_[1]), maps), bytes) <=
         limit_;
}

ServiceError MemoryBudget::Exhausted(std::uint64_t bytes, std::string_view what,
                                     std::uint64_t maps) const {
  const std::uint64_t used = SaturatingAdd(SaturatingAdd(reserved_[0], reserved_[1]), maps);
  const std::uint64_t free = used < limit_ ? limit_ - used : 0;
  std::string message(what);
  message += " needs " + MebibytesText(bytes) + ", and the server's memory budget (--max-memory " +
             MebibytesText(limit_) + ") has " + MebibytesText(free) + " free (maps held " +
             MebibytesText(maps) + ", uploads and maps waiting " +
             MebibytesText(reserved_[Index(Use::kUploads)]) + ", maps being made " +
             MebibytesText(reserved_[Index(Use::kAssessments)]) +
             "): delete maps, retry when work in progress has finished, or raise --max-memory";
  return MakeError(ErrorCode::kResourceExhausted, std::move(message))
      .With("needed_bytes", std::to_string(bytes))
      .With("free_bytes", std::to_string(free));
}

void MemoryBudget::Unreserve(Use use, std::uint64_t bytes) {
  std::lock_guard lock(mutex_);
  std::uint64_t& reserved = reserved_[Index(use)];
  reserved -= std::min(reserved, bytes);
}

void MemoryBudget::FitMaps() {
  if (limit_ == 0 || !held_bytes_) return;
  const std::uint64_t allowance = MapAllowance();
  if (held_bytes_() > allowance) trim_(allowance);
}

std::uint64_t MemoryBudget::MapAllowance() const {
  std::lock_guard lock(mutex_);
  if (limit_ == 0) return kNoLimit;
  const std::uint64_t reserved = SaturatingAdd(reserved_[0], reserved_[1]);
  return reserved < limit_ ? limit_ - reserved : 0;
}

std::uint64_t MemoryBudget::reserved(Use use) const {
  std::lock_guard lock(mutex_);
  return reserved_[Index(use)];
}

std::uint64_t MemoryBudget::map_bytes() const { return held_bytes_ ? held_bytes_() : 0; }

}  // namespace strata::server
