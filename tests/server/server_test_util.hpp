#pragma once
// Helpers for tests that talk to a running strata-server.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <google/rpc/error_details.pb.h>
#include <google/rpc/status.pb.h>
#include <grpcpp/grpcpp.h>

#include "strata/planner.hpp"
#include "strata/v1/map_service.grpc.pb.h"
#include "strata/v1/planner_service.grpc.pb.h"
#include "test_util/time_scale.hpp"

namespace strata::server::testing {

/// What a failed call carried: code, message, ErrorInfo and BadRequest fields.
struct CallError {
  grpc::StatusCode code = grpc::StatusCode::OK;
  std::string message;
  std::string reason;               ///< ErrorInfo.reason; empty without details.
  std::string domain;               ///< ErrorInfo.domain.
  std::vector<std::string> fields;  ///< BadRequest field violations.
};

inline CallError ErrorOf(const grpc::Status& status) {
  CallError error;
  error.code = status.error_code();
  error.message = status.error_message();
  google::rpc::Status details;
  if (!details.ParseFromString(status.error_details())) return error;
  for (const auto& detail : details.details()) {
    google::rpc::ErrorInfo info;
    google::rpc::BadRequest bad_request;
    if (detail.UnpackTo(&info)) {
      error.reason = info.reason();
      error.domain = info.domain();
    } else if (detail.UnpackTo(&bad_request)) {
      for (const auto& v : bad_request.field_violations()) error.fields.push_back(v.field());
    }
  }
  return error;
}

inline void SetDeadline(grpc::ClientContext* context, double seconds) {
  context->set_deadline(std::chrono::system_clock::now() +
                        std::chrono::duration_cast<std::chrono::system_clock::duration>(
                            std::chrono::duration<double>(seconds)));
}

inline void SetXyz(v1::Vector3* v, double x, double y, double z) {
  v->set_x(x);
  v->set_y(y);
  v->set_z(z);
}

/// The first message of an UploadMap stream: map `map_id`, points as little-endian float32
/// x, y, z, `point_count` of them announced (0: any number).
inline v1::UploadMapRequest UploadHeader(const std::string& map_id, std::uint64_t point_count = 0) {
  v1::UploadMapRequest message;
  message.mutable_header()->set_map_id(map_id);
  message.mutable_header()->set_format(v1::POINT_FORMAT_XYZ_F32_LE);
  message.mutable_header()->set_point_count(point_count);
  return message;
}

inline v1::PlanRequest PlanRequestFor(const std::string& map_id, double sx, double sy, double sz,
                                      double gx, double gy, double gz) {
  v1::PlanRequest request;
  request.set_map_id(map_id);
  request.set_profile_name("differential");
  SetXyz(request.mutable_start()->mutable_position_m(), sx, sy, sz);
  SetXyz(request.mutable_goal()->mutable_position_m(), gx, gy, gz);
  // The product's default budget (PlanOptions), in the time of this build: a sanitised one
  // runs several times slower, and the first plan on a map builds its graph within it.
  request.mutable_options()->set_time_budget_s(PlanOptions().time_budget_s * test_util::kTimeScale);
  return request;
}

/// Sets `prism` to the box [x0, x1] × [y0, y1] × [z0, z1] [m].
inline void SetBox(v1::Prism* prism, double x0, double y0, double x1, double y1, double z0,
                   double z1) {
  for (const auto& [x, y] : {std::pair{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}) {
    v1::Vector2* corner = prism->add_polygon_m();
    corner->set_x(x);
    corner->set_y(y);
  }
  prism->set_z_min_m(z0);
  prism->set_z_max_m(z1);
}

/// Smallest distance of the response's trajectory samples to the vertical line at (x, y) [m].
inline double ClosestApproach(const v1::PlanResponse& response, double x, double y) {
  double closest = 1e9;
  for (const v1::TrajectorySample& sample : response.samples()) {
    closest =
        std::min(closest, std::hypot(sample.position_m().x() - x, sample.position_m().y() - y));
  }
  return closest;
}

}  // namespace strata::server::testing
