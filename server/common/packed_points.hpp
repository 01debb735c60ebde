#pragma once
/// Points as packed little-endian IEEE-754 float32 triples x, y, z, 12 bytes each: the one
/// byte format of points on the wire and between the server and its workers (UploadMap's
/// chunks in POINT_FORMAT_XYZ_F32_LE, UpdateMap's MapEdit.scan.points, a scan's points in a
/// worker's edits file, maps/map_worker_protocol.hpp). Bit for bit: a point read back is the
/// point written, NaN payloads included.
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include <Eigen/Core>

namespace strata::server {

/// Bytes per packed point.
inline constexpr std::size_t kPackedPointBytes = 12;

/// `bits` in little-endian byte order (itself on a little-endian machine), and back.
inline std::uint32_t LittleEndianBits(std::uint32_t bits) {
  if constexpr (std::endian::native == std::endian::big) {
    bits =
        ((bits & 0xFFu) << 24) | ((bits & 0xFF00u) << 8) | ((bits >> 8) & 0xFF00u) | (bits >> 24);
  }
  return bits;
}

/// The float whose little-endian bytes start at `bytes`.
inline float ReadLittleEndianFloat(const char* bytes) {
  std::uint32_t bits = 0;
  std::memcpy(&bits, bytes, sizeof(bits));
  return std::bit_cast<float>(LittleEndianBits(bits));
}

/// The point packed at `bytes` (kPackedPointBytes of them).
inline Eigen::Vector3f ReadPackedPoint(const char* bytes) {
  return {ReadLittleEndianFloat(bytes), ReadLittleEndianFloat(bytes + 4),
          ReadLittleEndianFloat(bytes + 8)};
}

/// Appends `p` to `out`, packed.
inline void AppendPackedPoint(const Eigen::Vector3f& p, std::string* out) {
  for (int axis = 0; axis < 3; ++axis) {
    const std::uint32_t bits = LittleEndianBits(std::bit_cast<std::uint32_t>(p[axis]));
    char bytes[sizeof(bits)];
    std::memcpy(bytes, &bits, sizeof(bits));
    out->append(bytes, sizeof(bytes));
  }
}

}  // namespace strata::server
