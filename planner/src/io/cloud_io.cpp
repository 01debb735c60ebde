#include "strata/io/cloud_io.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <new>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "io/cloud_io_internal.hpp"

namespace strata {
namespace internal {

Error LoadError(std::string_view path, const std::string& problem) {
  return Error{ErrorCode::kMapLoadFailed, Cat(path, ": ", problem)};
}

Error TooBig(std::string_view path, const std::string& what, std::uint64_t limit,
             const char* field) {
  return Error{ErrorCode::kResourceExhausted, Cat(path, ": ", what, ", more than the limit of ",
                                                  limit, " (CloudLoadLimits::", field, ")")};
}

std::vector<std::string_view> Tokens(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t pos = 0;
  while ((pos = line.find_first_not_of(kWordSeparators, pos)) != std::string_view::npos) {
    const std::size_t end = std::min(line.find_first_of(kWordSeparators, pos), line.size());
    tokens.push_back(line.substr(pos, end - pos));
    pos = end;
  }
  return tokens;
}

std::optional<std::uint64_t> ParseCount(std::string_view token) {
  std::uint64_t value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || end != token.data() + token.size()) return std::nullopt;
  return value;
}

std::string_view NextLine(std::string_view bytes, std::size_t* pos) {
  const std::size_t eol = std::min(bytes.find('\n', *pos), bytes.size());
  const std::string_view line = bytes.substr(*pos, eol - *pos);
  *pos = std::min(eol + 1, bytes.size());
  return line;
}

}  // namespace internal

namespace {

using internal::Cat;
using internal::LoadError;

Status CheckLimits(const CloudLoadLimits& limits) {
  const auto bad = [](const char* field) {
    return Error{ErrorCode::kInvalidConfig,
                 Cat("CloudLoadLimits::", field, " must be > 0 (and finite)")};
  };
  if (limits.max_points == 0) return bad("max_points");
  if (limits.max_file_bytes == 0) return bad("max_file_bytes");
  if (!(limits.max_abs_coordinate_m > 0.0) || !std::isfinite(limits.max_abs_coordinate_m)) {
    return bad("max_abs_coordinate_m");
  }
  return Status::Ok();
}

// Every format is read from memory: the limits are checked against the real size before
// anything is allocated, and the readers all see the same bytes the checks saw.
Expected<std::string> ReadWholeFile(const NamedFile& file, const CloudLoadLimits& limits) {
  const std::string& path = file.path;
  const std::string& name = file.name;
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  if (status.type() == std::filesystem::file_type::not_found) {
    return LoadError(name, "file not found; check the path");
  }
  if (ec) return LoadError(name, "cannot access the file: " + ec.message());
  if (std::filesystem::is_directory(status)) {
    return LoadError(name, "is a directory, not a point-cloud file");
  }
  // A FIFO or a device could block forever or never end.
  if (!std::filesystem::is_regular_file(status)) return LoadError(name, "is not a regular file");
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return LoadError(name, "cannot read the file size: " + ec.message());
  if (size == 0) return LoadError(name, "file is empty (0 bytes)");
  if (size > limits.max_file_bytes) {
    return internal::TooBig(name, Cat("file is ", size, " bytes"), limits.max_file_bytes,
                            "max_file_bytes");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return LoadError(name, "cannot open the file for reading; check its permissions");
  std::string bytes(size, '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size) {
    return LoadError(name, "could not read the whole file (did it change while loading?)");
  }
  return bytes;
}

}  // namespace

Expected<LoadedCloud> LoadPointCloud(const NamedFile& file, const CloudLoadLimits& limits) {
  const std::string& name = file.name;
  if (Status status = CheckLimits(limits); !status.ok()) return status.error();
  std::string extension = std::filesystem::path(name).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension != ".pcd" && extension != ".ply" && extension != ".bt" && extension != ".ot") {
    return LoadError(name, Cat("unsupported extension ", internal::Quote(extension),
                               "; supported: .pcd, .ply, .bt, .ot"));
  }
  // PCL and OctoMap are third-party code: whatever they throw becomes an error here.
  try {
    Expected<std::string> bytes = ReadWholeFile(file, limits);
    if (!bytes.ok()) return bytes.error();
    Expected<LoadedCloud> cloud =
        extension == ".pcd"   ? internal::LoadPcd(name, *bytes, limits)
        : extension == ".ply" ? internal::LoadPly(name, *bytes, limits)
                              : internal::LoadOctree(name, *bytes, limits, extension == ".bt");
    if (cloud.ok() && cloud->points.empty()) {
      return LoadError(name, cloud->raw_point_count == 0
                                 ? std::string("contains no points")
                                 : Cat("contains no finite points (all ", cloud->raw_point_count,
                                       " have NaN/Inf coordinates)"));
    }
    return cloud;
  } catch (const std::bad_alloc&) {
    return Error{ErrorCode::kResourceExhausted,
                 Cat(name, ": ran out of memory while loading; lower CloudLoadLimits")};
  } catch (const std::exception& e) {
    return LoadError(name, Cat("could not be read: ", e.what()));
  } catch (...) {
    return LoadError(name, "could not be read (the reader failed)");
  }
}

Expected<LoadedCloud> SanitizeCloud(PointCloud raw, const CloudLoadLimits& limits) {
  if (Status status = CheckLimits(limits); !status.ok()) return status.error();
  if (raw.size() > limits.max_points) {
    return internal::TooBig("cloud", Cat("holds ", raw.size(), " points"), limits.max_points,
                            "max_points");
  }
  // In place: the points kept move to the front, so a large cloud is never held twice.
  const double bound = internal::CoordinateBound(limits);
  LoadedCloud out;
  out.raw_point_count = raw.size();
  std::size_t kept = 0;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const Eigen::Vector3f p = raw[i];
    if (!p.allFinite()) {
      ++out.dropped_nonfinite;
      continue;
    }
    if (Status s = internal::CheckCoordinates("cloud", i, p.cast<double>(), bound, limits); !s) {
      return s.error();
    }
    raw[kept++] = p;
  }
  if (kept == 0) {
    return Error{ErrorCode::kInvalidInput,
                 Cat("cloud contains no finite points (", raw.size(), " given)")};
  }
  raw.resize(kept);
  out.points = std::move(raw);
  return out;
}

}  // namespace strata
