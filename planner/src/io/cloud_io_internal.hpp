#pragma once
/// Shared by the map loaders (cloud_io.cpp, cloud_io_pcl.cpp, cloud_io_octomap.cpp); not
/// installed. Each loader gets the whole file already in memory, checked against the limits on
/// file size, and returns errors whose message starts with the path.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <streambuf>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "format_internal.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/status.hpp"

namespace strata::internal {

/// Concatenates the arguments as an ostream prints them (doubles with 6 significant digits).
template <typename... Args>
std::string Cat(const Args&... args) {
  std::ostringstream os;
  (os << ... << args);
  return os.str();
}

/// kMapLoadFailed with "<path>: <problem>".
Error LoadError(std::string_view path, const std::string& problem);

/// kResourceExhausted: "<path>: <what>, more than the limit of <limit> (CloudLoadLimits::<field>)".
Error TooBig(std::string_view path, const std::string& what, std::uint64_t limit,
             const char* field);

/// What separates the words of a header line: spaces, tabs and carriage returns.
inline constexpr std::string_view kWordSeparators = " \t\r";

/// The words of `line`, split at kWordSeparators.
std::vector<std::string_view> Tokens(std::string_view line);

/// A decimal count >= 0 filling the whole token; nullopt otherwise.
std::optional<std::uint64_t> ParseCount(std::string_view token);

/// The line of `bytes` starting at *pos, without its '\n'; moves *pos past the '\n'.
std::string_view NextLine(std::string_view bytes, std::size_t* pos);

/// Lets PCL and OctoMap parse bytes already read and checked, without copying them and without
/// reading again a file that may have changed since. Read-only, seekable.
class MemoryStreambuf : public std::streambuf {
 public:
  explicit MemoryStreambuf(std::string_view bytes) {
    char* begin = const_cast<char*>(bytes.data());  // Get area only: never written through.
    setg(begin, begin, begin + bytes.size());
  }

 protected:
  pos_type seekoff(off_type off, std::ios_base::seekdir dir, std::ios_base::openmode) override {
    const off_type base = dir == std::ios_base::beg   ? 0
                          : dir == std::ios_base::cur ? gptr() - eback()
                                                      : egptr() - eback();
    if (base + off < 0 || base + off > egptr() - eback()) return pos_type(off_type(-1));
    setg(eback(), eback() + base + off, egptr());
    return pos_type(base + off);
  }
  pos_type seekpos(pos_type pos, std::ios_base::openmode mode) override {
    return seekoff(off_type(pos), std::ios_base::beg, mode);
  }
};

/// The sanitising every loader and SanitizeCloud share: drops non-finite points (counting
/// them) and fails on more than limits.max_points points (kResourceExhausted) or a coordinate
/// beyond limits.max_abs_coordinate_m (kInvalidInput). `point_at(i)` yields point i in double
/// precision, so an F8 coordinate of 1e300 is reported as out of range, not as an infinity.
/// An empty result is not an error here: the callers word that failure themselves.
/// The largest |coordinate| a point may have: the configured limit, and never beyond float
/// range (a coordinate there cannot be stored).
inline double CoordinateBound(const CloudLoadLimits& limits) {
  return std::min(limits.max_abs_coordinate_m, double{std::numeric_limits<float>::max()});
}

/// kInvalidInput when the finite point `p` (number `i` of `source`) lies beyond `bound`.
inline Status CheckCoordinates(std::string_view source, std::size_t i, const Eigen::Vector3d& p,
                               double bound, const CloudLoadLimits& limits) {
  if (!(p.cwiseAbs().maxCoeff() > bound)) return Status::Ok();
  return Error{ErrorCode::kInvalidInput,
               Cat(source, ": point ", i, " at (", p.x(), ", ", p.y(), ", ", p.z(),
                   ") m lies beyond the ", limits.max_abs_coordinate_m,
                   " m coordinate limit; check the units (CloudLoadLimits::"
                   "max_abs_coordinate_m)")};
}

template <typename PointAt>
Expected<LoadedCloud> SanitizePoints(std::size_t count, const PointAt& point_at,
                                     std::string_view source, const CloudLoadLimits& limits) {
  if (count > limits.max_points) {
    return TooBig(source, Cat("holds ", count, " points"), limits.max_points, "max_points");
  }
  const double bound = CoordinateBound(limits);
  LoadedCloud out;
  out.raw_point_count = count;
  out.points.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const Eigen::Vector3d p = point_at(i);
    if (!p.allFinite()) {
      ++out.dropped_nonfinite;
      continue;
    }
    if (Status s = CheckCoordinates(source, i, p, bound, limits); !s) return s.error();
    out.points.push_back(p.cast<float>());
  }
  return out;
}

/// PCD in any encoding, read by PCL (cloud_io_pcl.cpp). May throw what PCL throws.
Expected<LoadedCloud> LoadPcd(const std::string& path, std::string_view bytes,
                              const CloudLoadLimits& limits);

/// PLY, read by PCL (cloud_io_pcl.cpp). May throw what PCL throws.
Expected<LoadedCloud> LoadPly(const std::string& path, std::string_view bytes,
                              const CloudLoadLimits& limits);

/// OctoMap .bt (`binary`) or .ot; one point per occupied finest-resolution voxel
/// (cloud_io_octomap.cpp). May throw std::bad_alloc.
Expected<LoadedCloud> LoadOctree(const std::string& path, std::string_view bytes,
                                 const CloudLoadLimits& limits, bool binary);

}  // namespace strata::internal
