#include "common/log.hpp"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>

namespace strata::server {
namespace {

std::atomic<int> g_level{static_cast<int>(LogLevel::kInfo)};

void AppendTimestamp(std::string* line) {
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const auto millis =
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", utc.tm_year + 1900,
                utc.tm_mon + 1, utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec,
                static_cast<int>(millis));
  *line += buf;
}

// Appends `value` quoted when it needs to be, escaping quotes, backslashes and control
// characters, and cut at kMaxValueLength characters.
void AppendValue(std::string* line, std::string_view value) {
  const bool truncated = value.size() > LogRecord::kMaxValueLength;
  if (truncated) value = value.substr(0, LogRecord::kMaxValueLength);
  bool quote = value.empty() || truncated;
  for (const char c : value) {
    if (c == ' ' || c == '"' || c == '=' || c == '\\' || static_cast<unsigned char>(c) < 0x20) {
      quote = true;
      break;
    }
  }
  if (!quote) {
    *line += value;
    return;
  }
  *line += '"';
  for (const char c : value) {
    switch (c) {
      case '"': *line += "\\\""; break;
      case '\\': *line += "\\\\"; break;
      case '\n': *line += "\\n"; break;
      case '\r': *line += "\\r"; break;
      case '\t': *line += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\x%02x", static_cast<unsigned>(c));
          *line += buf;
        } else {
          *line += c;
        }
    }
  }
  if (truncated) *line += "...";
  *line += '"';
}

}  // namespace

const char* LogLevelName(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug: return "debug";
    case LogLevel::kInfo: return "info";
    case LogLevel::kWarning: return "warning";
    case LogLevel::kError: return "error";
  }
  return "info";
}

void SetLogLevel(LogLevel level) { g_level.store(static_cast<int>(level)); }

bool LogEnabled(LogLevel level) { return static_cast<int>(level) >= g_level.load(); }

bool ParseLogLevel(std::string_view text, LogLevel* level) {
  if (text == "debug")
    *level = LogLevel::kDebug;
  else if (text == "info")
    *level = LogLevel::kInfo;
  else if (text == "warning" || text == "warn")
    *level = LogLevel::kWarning;
  else if (text == "error")
    *level = LogLevel::kError;
  else
    return false;
  return true;
}

LogRecord::LogRecord(LogLevel level, std::string_view event) : enabled_(LogEnabled(level)) {
  if (!enabled_) return;
  line_.reserve(256);
  line_ += "ts=";
  AppendTimestamp(&line_);
  line_ += " level=";
  line_ += LogLevelName(level);
  Add("event", event);
}

LogRecord::~LogRecord() {
  if (!enabled_) return;
  line_ += '\n';
  // One write(2) per line: atomic with respect to other records for lines this short.
  const char* data = line_.data();
  std::size_t left = line_.size();
  while (left > 0) {
    const ssize_t written = ::write(STDERR_FILENO, data, left);
    if (written <= 0) break;
    data += written;
    left -= static_cast<std::size_t>(written);
  }
}

LogRecord& LogRecord::Add(std::string_view key, std::string_view value) {
  if (!enabled_) return *this;
  line_ += ' ';
  line_ += key;
  line_ += '=';
  AppendValue(&line_, value);
  return *this;
}

LogRecord& LogRecord::Add(std::string_view key, double value) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6g", value);
  return Add(key, std::string_view(buf));
}

LogRecord& LogRecord::Add(std::string_view key, long long value) {
  return Add(key, std::string_view(std::to_string(value)));
}

}  // namespace strata::server
