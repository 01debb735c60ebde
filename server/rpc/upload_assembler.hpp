#pragma once
/// Reassembles an UploadMap stream (header, then chunks of packed points) into a cloud,
/// checking every rule of the protocol as messages arrive, so a malformed or oversized
/// upload is refused at the first bad message rather than after it has all been received.
#include <cstddef>
#include <optional>

#include "common/packed_points.hpp"
#include "common/service_error.hpp"
#include "maps/map_registry.hpp"
#include "maps/memory_budget.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/v1/map_service.pb.h"

namespace strata::server {

class UploadAssembler {
 public:
  /// Largest chunk accepted [bytes] (1 MiB).
  static constexpr std::size_t kMaxChunkBytes = std::size_t{1} << 20;
  /// Bytes per point of POINT_FORMAT_XYZ_F32_LE.
  static constexpr std::size_t kPointBytes = kPackedPointBytes;

  /// `max_points`: the server's limit on one map [-], > 0. `budget` (may be null): the
  /// server's memory budget, which the points are counted in as they arrive (their vector's
  /// capacity: all of header.point_count at the header when it is given).
  explicit UploadAssembler(std::size_t max_points, MemoryBudget* budget = nullptr)
      : max_points_(max_points), budget_(budget) {}

  /// Takes the next message. Fails with kMapLoadFailed (blaming the field) for a stream out
  /// of order or a malformed chunk, kInvalidInput / kInvalidConfig for a bad header, and
  /// kResourceExhausted past max_points or the memory budget.
  ServiceStatus Add(const v1::UploadMapRequest& message);

  /// After the last message: the map to create. Fails with kMapLoadFailed for an empty
  /// stream, no points, or a count other than the header's.
  ServiceStatus Finish();

  /// Valid after Add of the header.
  const v1::UploadHeader& header() const { return header_; }
  const AssessmentConfig& config() const { return config_; }
  std::size_t point_count() const { return source_.points.size(); }
  /// Moves the points out, with their share of the memory budget; after Finish().
  UploadMapSource TakeSource();

 private:
  // Makes room for `points` points, counting them in the budget; the error blames `field`.
  ServiceStatus Reserve(std::size_t points, const char* field);

  std::size_t max_points_;
  MemoryBudget* budget_;
  MemoryBudget::Reservation reservation_;
  bool have_header_ = false;
  v1::UploadHeader header_;
  AssessmentConfig config_;
  UploadMapSource source_;
  std::size_t messages_ = 0;
};

}  // namespace strata::server
