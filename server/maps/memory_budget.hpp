#pragma once
/// The server's one memory budget (--max-memory): the maps it holds (terrain models and their
/// traversability graphs), the uploads it is receiving and the maps waiting to be made (their
/// points), and the memory set aside for each map being made (its worker's limit), kept
/// together under one limit. Work that would pass it is refused before it starts, with
/// kResourceExhausted and the figures; maps a cache can let go are dropped first. No gRPC here.
#include <array>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <string_view>

#include "common/service_error.hpp"

namespace strata::server {

class MemoryBudget {
 public:
  /// What reserved bytes are for.
  enum class Use {
    kUploads,      ///< Points received or waiting to be made into a map.
    kAssessments,  ///< Maps being made or edited (a worker's memory limit).
  };

  /// Bytes held, then released on destruction or Release(). Move-only.
  class Reservation {
   public:
    Reservation() = default;
    Reservation(Reservation&& other) noexcept;
    Reservation& operator=(Reservation&& other) noexcept;
    Reservation(const Reservation&) = delete;
    Reservation& operator=(const Reservation&) = delete;
    ~Reservation() { Release(); }

    /// Adds `bytes` if the budget has room (as Reserve); unchanged otherwise.
    ServiceStatus Grow(std::uint64_t bytes, std::string_view what);
    void Release();
    std::uint64_t bytes() const { return bytes_; }

   private:
    friend class MemoryBudget;
    Reservation(MemoryBudget* budget, Use use, std::uint64_t bytes)
        : budget_(budget), use_(use), bytes_(bytes) {}
    MemoryBudget* budget_ = nullptr;
    Use use_ = Use::kUploads;
    std::uint64_t bytes_ = 0;
  };

  /// `limit_bytes` 0: no limit (everything is still counted).
  explicit MemoryBudget(std::uint64_t limit_bytes) : limit_(limit_bytes) {}
  MemoryBudget(const MemoryBudget&) = delete;
  MemoryBudget& operator=(const MemoryBudget&) = delete;

  /// How the maps held are counted (`held_bytes`) and how those nobody uses are let go when
  /// room is needed (`trim(target)` drops them until the maps hold at most `target` bytes, or
  /// none is left to drop). Set once, before any other call; both run without this budget's
  /// lock and may call MapAllowance().
  void WatchMaps(std::function<std::uint64_t()> held_bytes,
                 std::function<void(std::uint64_t target_bytes)> trim);

  /// Sets `bytes` aside for `use` if the maps held, what is reserved and they fit the limit
  /// (after trimming the maps); kResourceExhausted naming `what` ("uploading map 'x'") and
  /// the figures otherwise.
  Result<Reservation> Reserve(Use use, std::uint64_t bytes, std::string_view what);

  /// Whether a map of `bytes` more may be held now (after trimming); kResourceExhausted naming
  /// `what` and the figures otherwise. Reserves nothing: the map counts once it is held.
  ServiceStatus AdmitMap(std::uint64_t bytes, std::string_view what);

  /// Lets go of maps nobody uses until those held fit what the limit leaves them again (the
  /// trim WatchMaps set): a map is admitted by its model's bytes, and the graphs its first
  /// plans build or load grow it after. Nothing without a limit.
  void FitMaps();

  /// Bytes the maps may hold now: the limit less what is reserved (the largest value without
  /// a limit).
  std::uint64_t MapAllowance() const;

  std::uint64_t limit() const { return limit_; }
  std::uint64_t reserved(Use use) const;
  /// Bytes of the maps held (WatchMaps' count; 0 before it is set).
  std::uint64_t map_bytes() const;

 private:
  // Whether `bytes` more fit beside `maps` held and what is reserved; call with mutex_.
  bool FitsLocked(std::uint64_t bytes, std::uint64_t maps) const;
  ServiceError Exhausted(std::uint64_t bytes, std::string_view what, std::uint64_t maps) const;
  ServiceStatus Admit(std::uint64_t bytes, std::string_view what, Use* use);
  void Unreserve(Use use, std::uint64_t bytes);

  const std::uint64_t limit_;
  std::function<std::uint64_t()> held_bytes_;
  std::function<void(std::uint64_t)> trim_;
  mutable std::mutex mutex_;
  std::array<std::uint64_t, 2> reserved_{};  // By Use.
};

/// --max-memory's automatic value: 80 % of the memory this process may use, its cgroup's
/// limit (memory.max, as Kubernetes sets it) or else the machine's.
std::uint64_t AutomaticMemoryLimit();

/// "12.3 MiB".
std::string MebibytesText(std::uint64_t bytes);

}  // namespace strata::server
