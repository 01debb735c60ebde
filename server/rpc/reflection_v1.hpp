#pragma once
/// gRPC server reflection, version v1 (grpc.reflection.v1.ServerReflection), beside the
/// v1alpha one gRPC 1.51 serves: grpcurl and buf curl ask v1 first, and every session then
/// counted an Unimplemented call. Answers from the process's generated descriptor pool, so
/// every type the server links (the API, google.rpc error details, health) resolves, and the
/// error details of a failed call print as messages rather than base64.
#include <string>
#include <vector>

#include "grpc/reflection/v1/reflection.grpc.pb.h"

namespace strata::server {

class ReflectionV1Service final : public grpc::reflection::v1::ServerReflection::Service {
 public:
  /// `services`: the full names list_services answers (the services the server registered).
  explicit ReflectionV1Service(std::vector<std::string> services);

  grpc::Status ServerReflectionInfo(
      grpc::ServerContext* context,
      grpc::ServerReaderWriter<grpc::reflection::v1::ServerReflectionResponse,
                               grpc::reflection::v1::ServerReflectionRequest>* stream) override;

 private:
  const std::vector<std::string> services_;
};

}  // namespace strata::server
