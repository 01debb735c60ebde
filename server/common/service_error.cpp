#include "common/service_error.hpp"

#include <fmt/format.h>

namespace strata::server {

ServiceError ServiceError::FromPlanner(const Error& error, std::string field) {
  // The planner's details (e.g. the nearest valid point) travel as ErrorInfo metadata.
  ServiceError result{error.code, error.message, {}, error.details};
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

std::string BoundedText(std::string_view text, std::size_t max_bytes) {
  if (text.size() <= max_bytes) return std::string(text);
  std::size_t cut = max_bytes;
  // Back off to the start of a UTF-8 character (continuation bytes are 10xxxxxx).
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;
  return fmt::format("{}…[{} more bytes]", text.substr(0, cut), text.size() - cut);
}

}  // namespace strata::server
