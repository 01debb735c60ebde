#pragma once
// Local point clouds for `strata maps upload`, read a chunk at a time (never the whole file
// in memory) and converted to UploadMap's encoding: packed little-endian float32 x, y, z.
//
// Formats: PCD with DATA ascii or binary (x, y, z fields of type F, size 4 or 8; other fields
// are skipped; binary_compressed is refused), text with "x y z" per line (commas allowed,
// further columns and '#' comment lines ignored), and raw float32 x, y, z triples.
#include <cstdint>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

namespace strata::cli {

enum class PointFileFormat { kPcd, kText, kRawF32 };

/// "pcd", "xyz" (text) or "raw"; nullopt otherwise.
std::optional<PointFileFormat> ParsePointFileFormat(const std::string& name);
/// By extension: .pcd; .xyz, .txt, .csv (text); .bin, .raw, .f32 (raw). nullopt otherwise.
std::optional<PointFileFormat> GuessPointFileFormat(const std::string& path);

class PointFileReader {
 public:
  /// Opens `path` and reads its header; throws UsageError when it cannot be read or the
  /// format is not supported.
  PointFileReader(const std::string& path, PointFileFormat format);

  /// Points the file announces (PCD POINTS, raw size / 12); 0 when unknown (text).
  std::uint64_t point_count() const { return point_count_; }

  /// Replaces *chunk with up to `max_points` points (12 bytes each); false when none are
  /// left. Throws UsageError on a malformed or truncated file, naming the line or point.
  bool Next(std::size_t max_points, std::string* chunk);

 private:
  struct Field {
    std::size_t offset = 0;  // Byte offset in a binary record, or token index in ascii.
    int size = 4;            // 4 (float) or 8 (double).
  };

  void ReadPcdHeader();
  bool NextText(std::size_t max_points, std::string* chunk, bool pcd_ascii);
  bool NextBinary(std::size_t max_points, std::string* chunk);

  std::string path_;
  PointFileFormat format_;
  std::ifstream file_;
  std::uint64_t point_count_ = 0;
  std::uint64_t points_read_ = 0;
  std::uint64_t line_ = 0;
  bool pcd_binary_ = false;
  std::size_t record_bytes_ = 12;
  Field xyz_[3] = {{0, 4}, {4, 4}, {8, 4}};
};

}  // namespace strata::cli
