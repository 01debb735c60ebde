#include "service_error.hpp"

namespace strata::server {

ServiceError ServiceError::FromPlanner(const Error& error, std::string field) {
  ServiceError result{error.code, error.message, {}, {}};
  if (!field.empty()) result.Blame(std::move(field));
  return result;
}

ServiceError& ServiceError::Blame(std::string field) {
  field_violations.push_back({std::move(field), message});
  return *this;
}

ServiceError& ServiceError::With(std::string key, std::string value) {
  metadata[std::move(key)] = std::move(value);
  return *this;
}

ServiceError MakeError(ServiceErrorCode code, std::string message) {
  return ServiceError{code, std::move(message), {}, {}};
}

ServiceError MakeError(ErrorCode code, std::string message) {
  return ServiceError{code, std::move(message), {}, {}};
}

}  // namespace strata::server
