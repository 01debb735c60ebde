#include "rpc/upload_assembler.hpp"

#include "common/map_id.hpp"

#include <algorithm>
#include <string>

#include <fmt/format.h>

#include "common/packed_points.hpp"
#include "rpc/proto_convert.hpp"

namespace strata::server {

ServiceStatus UploadAssembler::Add(const v1::UploadMapRequest& message) {
  ++messages_;
  const std::string where = fmt::format("message {} of the stream", messages_);
  switch (message.part_case()) {
    case v1::UploadMapRequest::kHeader: {
      if (have_header_) {
        return MakeError(ErrorCode::kMapLoadFailed,
                         where + " is a second header: send the header once, first")
            .Blame("header");
      }
      have_header_ = true;
      header_ = message.header();
      if (!header_.map_id().empty()) {
        if (ServiceStatus valid = ValidateMapId(header_.map_id()); !valid.ok()) {
          ServiceError error = std::move(valid).error();
          error.field_violations.clear();
          return error.Blame("header.map_id");
        }
      }
      if (header_.format() != v1::POINT_FORMAT_XYZ_F32_LE) {
        return MakeError(ErrorCode::kInvalidInput,
                         "header.format must be POINT_FORMAT_XYZ_F32_LE (packed little-endian "
                         "float32 x, y, z)")
            .Blame("header.format");
      }
      Result<AssessmentConfig> config = FromProto(header_.terrain(), "header.terrain");
      if (!config.ok()) return std::move(config).error();
      config_ = config.value();
      if (header_.point_count() > max_points_) {
        return MakeError(ErrorCode::kResourceExhausted,
                         fmt::format("header.point_count = {} is above this server's limit of {} "
                                     "points per map (--max-points): downsample the cloud",
                                     header_.point_count(), max_points_))
            .Blame("header.point_count");
      }
      return Reserve(static_cast<std::size_t>(header_.point_count()), "header.point_count");
    }
    case v1::UploadMapRequest::kChunk: {
      if (!have_header_) {
        return MakeError(ErrorCode::kMapLoadFailed,
                         where + " is a chunk, but the first message must be the header")
            .Blame("header");
      }
      const std::string& bytes = message.chunk().points();
      if (bytes.size() > kMaxChunkBytes) {
        return MakeError(ErrorCode::kMapLoadFailed,
                         fmt::format("{} holds {} bytes of points, more than the 1 MiB (1048576 "
                                     "bytes) a chunk may hold: split it",
                                     where, bytes.size()))
            .Blame("chunk.points");
      }
      if (bytes.size() % kPointBytes != 0) {
        return MakeError(ErrorCode::kMapLoadFailed,
                         fmt::format("{} holds {} bytes, not a whole number of 12-byte points "
                                     "(float32 x, y, z)",
                                     where, bytes.size()))
            .Blame("chunk.points");
      }
      const std::size_t count = bytes.size() / kPointBytes;
      const std::size_t total = source_.points.size() + count;
      if (total > max_points_) {
        return MakeError(ErrorCode::kResourceExhausted,
                         fmt::format("the upload passed this server's limit of {} points per map "
                                     "(--max-points): downsample the cloud",
                                     max_points_))
            .Blame("chunk.points");
      }
      if (header_.point_count() != 0 && total > header_.point_count()) {
        return MakeError(ErrorCode::kMapLoadFailed,
                         fmt::format("{} brings the upload to {} points, more than "
                                     "header.point_count = {}",
                                     where, total, header_.point_count()))
            .Blame("header.point_count");
      }
      if (total > source_.points.capacity()) {
        // As the vector would grow, but counted first.
        if (ServiceStatus room =
                Reserve(std::max(total, 2 * source_.points.capacity()), "chunk.points");
            !room.ok()) {
          return room;
        }
      }
      source_.received_bytes += bytes.size();
      const char* data = bytes.data();
      for (std::size_t i = 0; i < count; ++i, data += kPointBytes) {
        source_.points.push_back(ReadPackedPoint(data));
      }
      return OkStatus();
    }
    case v1::UploadMapRequest::PART_NOT_SET: break;
  }
  return MakeError(ErrorCode::kMapLoadFailed, where + " sets neither header nor chunk")
      .Blame("part");
}

ServiceStatus UploadAssembler::Reserve(std::size_t points, const char* field) {
  const std::uint64_t bytes = std::uint64_t{points} * sizeof(PointCloud::value_type);
  if (budget_ != nullptr && bytes > reservation_.bytes()) {
    if (reservation_.bytes() == 0) {
      Result<MemoryBudget::Reservation> reserved = budget_->Reserve(
          MemoryBudget::Use::kUploads, bytes, "uploading map '" + header_.map_id() + "'");
      if (!reserved.ok()) return std::move(reserved).error().Blame(field);
      reservation_ = std::move(reserved).value();
    } else if (ServiceStatus grown = reservation_.Grow(bytes - reservation_.bytes(),
                                                       "uploading map '" + header_.map_id() + "'");
               !grown.ok()) {
      return std::move(grown).error().Blame(field);
    }
  }
  source_.points.reserve(points);
  return OkStatus();
}

UploadMapSource UploadAssembler::TakeSource() {
  source_.reservation = std::make_shared<MemoryBudget::Reservation>(std::move(reservation_));
  return std::move(source_);
}

ServiceStatus UploadAssembler::Finish() {
  if (!have_header_) {
    return MakeError(ErrorCode::kMapLoadFailed,
                     "the upload stream was empty: send a header, then chunks of points")
        .Blame("header");
  }
  // A stream gRPC cut off (a message above --max-receive-message-bytes) ends here too.
  constexpr const char* kCutOff =
      " (a chunk larger than --max-receive-message-bytes is refused by gRPC with "
      "RESOURCE_EXHAUSTED and ends the stream: chunks hold at most 1 MiB)";
  if (source_.points.empty()) {
    return MakeError(ErrorCode::kMapLoadFailed,
                     std::string("the upload carried no points") + kCutOff)
        .Blame("chunk");
  }
  if (header_.point_count() != 0 && source_.points.size() != header_.point_count()) {
    return MakeError(ErrorCode::kMapLoadFailed,
                     fmt::format("the upload carried {} points but header.point_count = {}: the "
                                 "stream was cut short or the count is wrong{}",
                                 source_.points.size(), header_.point_count(), kCutOff))
        .Blame("header.point_count");
  }
  return OkStatus();
}

}  // namespace strata::server
