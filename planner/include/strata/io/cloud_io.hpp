#pragma once
/// Reading point-cloud maps from files: PCD (ascii, binary, binary_compressed), PLY, and
/// OctoMap (.bt, .ot; occupied leaf centres become points). The format is chosen by extension.
/// Writing: binary PCD (SavePcd).

#include <cstddef>
#include <string>

#include "strata/named_file.hpp"
#include "strata/point_cloud.hpp"
#include "strata/status.hpp"

namespace strata {

/// Bounds that keep a hostile or broken file from exhausting memory.
struct CloudLoadLimits {
  std::size_t max_points = 50'000'000;                ///< Most points a file may hold [-], > 0.
  std::size_t max_file_bytes = std::size_t{4} << 30;  ///< Largest file accepted [bytes], > 0.
  /// Points farther from the origin on any axis are an error, not data [m], > 0.
  double max_abs_coordinate_m = kMaxAbsCoordinateM;
};

/// A loaded cloud with the bookkeeping the assessment summary reports.
struct LoadedCloud {
  PointCloud points;                  ///< Finite points only.
  std::size_t raw_point_count = 0;    ///< Points the file held, finite or not.
  std::size_t dropped_nonfinite = 0;  ///< Points dropped because a coordinate was NaN/Inf.
};

/// Loads `file.path`, in the format `file.name`'s extension says. Fails with kMapLoadFailed
/// naming the file (as `file.name`) and the problem when the file is
/// missing, unreadable, empty, truncated, not a point cloud, lacks x/y/z fields, or promises
/// more points than it holds; with kResourceExhausted when it exceeds `limits`; with
/// kInvalidInput when a coordinate is beyond limits.max_abs_coordinate_m. PCD headers that say
/// WIDTH 0 HEIGHT 0 with POINTS set (as real-world exporters write) are accepted. A file whose
/// points are all NaN/Inf fails with kMapLoadFailed; invalid `limits` with kInvalidConfig.
/// OctoMap files give one point per occupied voxel at the tree's resolution (a pruned leaf gives
/// every voxel it covers), and limits.max_points also bounds the number of tree nodes read.
Expected<LoadedCloud> LoadPointCloud(const NamedFile& file, const CloudLoadLimits& limits = {});

/// Drops non-finite points and rejects coordinates beyond `max_abs_coordinate_m`, the same
/// sanitising LoadPointCloud applies; for clouds that arrive from elsewhere (uploads, generated
/// clouds). Fails with kResourceExhausted above limits.max_points, kInvalidInput for a
/// coordinate beyond the limit or when no finite point remains, kInvalidConfig for invalid
/// `limits`.
Expected<LoadedCloud> SanitizeCloud(PointCloud raw, const CloudLoadLimits& limits = {});

/// Writes `cloud` to `path` as a binary PCD with float32 fields x, y, z (PCL's writer), one row
/// (WIDTH = points, HEIGHT = 1), overwriting an existing file. LoadPointCloud reads it back
/// exactly. Fails with kInvalidInput naming the path for an empty cloud or when the file cannot
/// be written.
Status SavePcd(const PointCloud& cloud, const std::string& path);

}  // namespace strata
