#pragma once
/// Structured logs: one line per record on stderr, logfmt (`ts=… level=info event=rpc
/// rpc=Plan map=demo duration_ms=12.3 result=OK`), written with a single write so lines
/// from concurrent threads never interleave. Values are escaped and cut at kMaxValueLength
/// characters, so no request can flood the log or forge a line.
#include <cstddef>
#include <string>
#include <string_view>

namespace strata::server {

enum class LogLevel { kDebug = 0, kInfo = 1, kWarning = 2, kError = 3 };

/// Records below `level` are dropped. Default kInfo. Thread-safe.
void SetLogLevel(LogLevel level);
bool LogEnabled(LogLevel level);
/// "debug", "info", "warning" (or "warn"), "error"; false for anything else.
bool ParseLogLevel(std::string_view text, LogLevel* level);
/// "debug", "info", "warning", "error": what ParseLogLevel reads back.
const char* LogLevelName(LogLevel level);

/// A record being built; it is written when destroyed.
class LogRecord {
 public:
  static constexpr std::size_t kMaxValueLength = 256;

  LogRecord(LogLevel level, std::string_view event);
  ~LogRecord();
  LogRecord(const LogRecord&) = delete;
  LogRecord& operator=(const LogRecord&) = delete;

  LogRecord& Add(std::string_view key, std::string_view value);
  LogRecord& Add(std::string_view key, const char* value) {
    return Add(key, std::string_view(value));
  }
  LogRecord& Add(std::string_view key, const std::string& value) {
    return Add(key, std::string_view(value));
  }
  LogRecord& Add(std::string_view key, double value);
  LogRecord& Add(std::string_view key, long long value);
  LogRecord& Add(std::string_view key, int value) {
    return Add(key, static_cast<long long>(value));
  }
  LogRecord& Add(std::string_view key, std::size_t value) {
    return Add(key, static_cast<long long>(value));
  }

 private:
  bool enabled_;
  std::string line_;
};

/// Shorthands.
inline LogRecord LogInfo(std::string_view event) { return LogRecord(LogLevel::kInfo, event); }
inline LogRecord LogWarning(std::string_view event) { return LogRecord(LogLevel::kWarning, event); }
inline LogRecord LogError(std::string_view event) { return LogRecord(LogLevel::kError, event); }

}  // namespace strata::server
