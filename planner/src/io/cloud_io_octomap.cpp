// OctoMap loading (see cloud_io_internal.hpp).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <istream>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include <octomap/OcTree.h>

#include "io/cloud_io_internal.hpp"

namespace strata::internal {
namespace {

constexpr unsigned kOctreeDepth = 16;  // OcTree's fixed depth.
// A pruned block comes back as its surface voxels only, and at most this many of them per byte
// of the file: a real map's blocks are thin slabs and small solids (a few per byte), while a
// file of a few hundred bytes could otherwise name tens of millions of voxels and hold an
// assessment for minutes.
constexpr std::uint64_t kMaxSurfaceVoxelsPerByte = 2000;

// Voxels on the faces of a cube of n voxels a side: the only ones that can be ground or an
// obstacle's surface (the inside is solid, under its own top and away from every free cell).
std::uint64_t SurfaceVoxels(std::uint64_t n) {
  return n < 3 ? n * n * n : n * n * n - (n - 2) * (n - 2) * (n - 2);
}

struct OctreeHeader {
  std::string id;
  std::uint64_t nodes = 0;
  double resolution_m = 0.0;
  std::size_t data_offset = 0;
};

Expected<OctreeHeader> ReadOctreeHeader(const std::string& path, std::string_view bytes,
                                        bool binary) {
  const std::string_view want = binary ? "# Octomap OcTree binary file" : "# Octomap OcTree file";
  const std::string_view other = binary ? "# Octomap OcTree file" : "# Octomap OcTree binary file";
  std::size_t pos = 0;
  const std::string_view first = NextLine(bytes, &pos);
  if (first.substr(0, other.size()) == other) {
    return LoadError(path, Cat("is an OctoMap ", binary ? ".ot" : ".bt", " file; rename it to ",
                               binary ? ".ot" : ".bt"));
  }
  if (first.substr(0, want.size()) != want) {
    return LoadError(
        path, Cat("does not start with '", want, "'; is this an OctoMap ", binary ? ".bt" : ".ot",
                  " file? (legacy .bt files need ", "convert_octree)"));
  }
  // Same token rules as octomap::AbstractOcTree::readHeader.
  OctreeHeader header;
  std::optional<std::uint64_t> nodes;
  const auto token = [&] {
    pos = std::min(bytes.find_first_not_of(" \t\r\n", pos), bytes.size());
    const std::size_t end = std::min(bytes.find_first_of(" \t\r\n", pos), bytes.size());
    const std::string_view word = bytes.substr(pos, end - pos);
    pos = end;
    return word;
  };
  while (pos < bytes.size()) {
    const std::string_view word = token();
    if (word == "data" || word.substr(0, 1) == "#") {
      NextLine(bytes, &pos);
      if (word == "data") {
        header.data_offset = pos;
        break;
      }
    } else if (word == "id") {
      header.id = token();
    } else if (word == "size") {
      nodes = ParseCount(token());
    } else if (word == "res") {
      const std::string_view value = token();
      const auto [end, ec] =
          std::from_chars(value.data(), value.data() + value.size(), header.resolution_m);
      if (ec != std::errc() || end != value.data() + value.size()) header.resolution_m = 0.0;
    } else if (!word.empty()) {
      return LoadError(path, Cat("unknown keyword ", Quote(word), " in the OctoMap header"));
    }
  }
  if (header.data_offset == 0) return LoadError(path, "OctoMap header has no 'data' line");
  if (header.id == "1") header.id = "OcTree";  // OctoMap's deprecated id.
  if (header.id.empty() || !nodes || *nodes > std::numeric_limits<unsigned>::max() ||
      !(header.resolution_m > 0.0) || !std::isfinite(header.resolution_m)) {
    return LoadError(path, "OctoMap header needs an id, a node count and a resolution > 0");
  }
  header.nodes = *nodes;
  return header;
}

struct OctreeWalk {
  std::string_view data;
  bool binary = true;
  std::size_t pos = 0;
  std::uint64_t nodes = 0;
  std::uint64_t surface_voxels = 0;  // Finest-resolution voxels on occupied leaves' faces.
  const char* problem = nullptr;

  void AddOccupied(unsigned depth) {
    const std::uint64_t voxels = SurfaceVoxels(std::uint64_t{1} << (kOctreeDepth - depth));
    surface_voxels = std::min(surface_voxels + voxels, std::uint64_t{1} << 62);
  }
  bool Fail(const char* why) {
    problem = why;
    return false;
  }

  // Mirrors OccupancyOcTreeBase::readBinaryNode (.bt: 2 bits per child) and
  // OcTreeBaseImpl::readNodesRecurs (.ot: a float log-odds and a child bitmask per node).
  bool Node(unsigned depth) {
    const std::size_t record = binary ? 2 : 5;
    if (data.size() - pos < record) return Fail("the tree data ends early (truncated file?)");
    const auto* p = reinterpret_cast<const std::uint8_t*>(data.data() + pos);
    pos += record;
    if (depth == 0) ++nodes;
    if (!binary) {
      float log_odds = 0.0f;
      std::memcpy(&log_odds, p, sizeof log_odds);
      if (p[4] == 0) {
        if (log_odds >= 0.0f) AddOccupied(depth);  // OcTree's default occupancy threshold.
        return true;
      }
      if (depth >= kOctreeDepth) return Fail("the tree nests deeper than 16 levels (corrupt?)");
      for (unsigned child = 0; child < 8; ++child) {
        if ((p[4] >> child) & 1u) {
          ++nodes;
          if (!Node(depth + 1)) return false;
        }
      }
      return true;
    }
    const unsigned bits = p[0] | (p[1] << 8);
    if (bits == 0) AddOccupied(depth);  // A childless node stays occupied (upper bound).
    for (unsigned child = 0; child < 8; ++child) {
      const unsigned kind = (bits >> (2 * child)) & 3u;  // 1 free, 2 occupied, 3 inner.
      nodes += kind != 0;
      if (kind == 2) AddOccupied(depth + 1);
    }
    for (unsigned child = 0; child < 8; ++child) {
      if (((bits >> (2 * child)) & 3u) != 3u) continue;
      if (depth + 1 >= kOctreeDepth) {
        return Fail("the tree nests deeper than 16 levels (corrupt?)");
      }
      if (!Node(depth + 1)) return false;
    }
    return true;
  }
};

}  // namespace

// OctoMap neither bounds the tree depth nor notices the end of its stream (it then decodes
// uninitialised bytes and may recurse without end), so the node structure is walked first,
// exactly as OctoMap will read it, and only a well-formed tree is handed to it.
Expected<LoadedCloud> LoadOctree(const std::string& path, std::string_view bytes,
                                 const CloudLoadLimits& limits, bool binary) {
  Expected<OctreeHeader> header = ReadOctreeHeader(path, bytes, binary);
  if (!header.ok()) return header.error();
  if (!binary && header->id != "OcTree") {
    return LoadError(path, Cat("holds an OctoMap ", Quote(header->id), ", not an OcTree; ",
                               "convert it to an OcTree"));
  }
  if (header->nodes == 0) return LoadError(path, "contains no points (an empty OctoMap)");
  OctreeWalk walk{bytes.substr(header->data_offset), binary};
  if (!walk.Node(0)) return LoadError(path, walk.problem);
  if (walk.nodes != header->nodes) {
    return LoadError(path, Cat("OctoMap header says ", header->nodes, " nodes but the data holds ",
                               walk.nodes, " (corrupt file?)"));
  }
  // The nodes and, once pruned blocks are expanded, the voxels are what cost memory and time.
  if (walk.nodes > limits.max_points || walk.surface_voxels > limits.max_points) {
    return TooBig(path,
                  Cat("OctoMap holds ", walk.nodes, " nodes and ", walk.surface_voxels,
                      " occupied surface voxels"),
                  limits.max_points, "max_points");
  }
  if (walk.surface_voxels > kMaxSurfaceVoxelsPerByte * bytes.size()) {
    return LoadError(path,
                     Cat("OctoMap of ", bytes.size(), " bytes expands to ", walk.surface_voxels,
                         " occupied surface voxels, more than ", kMaxSurfaceVoxelsPerByte,
                         " per byte of file: a real map is not pruned into blocks that "
                         "large; store it at its own resolution (or as a PCD)"));
  }

  // Only the data is handed over: OctoMap's own file readers (readBinary, AbstractOcTree::read)
  // print progress to stderr in Debian's build, and the header has been read above anyway.
  MemoryStreambuf buffer(bytes.substr(header->data_offset));
  std::istream in(&buffer);
  auto tree = std::make_unique<octomap::OcTree>(header->resolution_m);
  if (binary) {
    tree->readBinaryData(in);
  } else {
    tree->readData(in);
  }
  if (tree->size() != header->nodes) return LoadError(path, "OctoMap could not read the tree");

  // A pruned leaf stands for a solid block of voxels; its centre alone would misplace the
  // block's surfaces, so every finest-resolution voxel on its faces becomes a point.
  PointCloud points;
  points.reserve(walk.surface_voxels);
  const double resolution = tree->getResolution();
  for (auto it = tree->begin_leafs(), end = tree->end_leafs(); it != end; ++it) {
    if (!tree->isNodeOccupied(*it)) continue;
    const int per_axis = 1 << (tree->getTreeDepth() - it.getDepth());
    const octomap::point3d centre = it.getCoordinate();
    const Eigen::Vector3d corner =
        Eigen::Vector3d(centre.x(), centre.y(), centre.z()).array() - 0.5 * it.getSize();
    if (points.size() + SurfaceVoxels(per_axis) > limits.max_points) {
      return TooBig(path, "OctoMap expands to more voxels", limits.max_points, "max_points");
    }
    const int last = per_axis - 1;
    for (int i = 0; i < per_axis; ++i) {
      for (int j = 0; j < per_axis; ++j) {
        // Inside the block only its bottom and top voxels (k = 0 and last) are on a face.
        const bool side = i == 0 || i == last || j == 0 || j == last;
        const int step = side || last == 0 ? 1 : last;
        for (int k = 0; k < per_axis; k += step) {
          const Eigen::Vector3d offset(i + 0.5, j + 0.5, k + 0.5);
          points.push_back((corner + resolution * offset).cast<float>());
        }
      }
    }
  }
  return SanitizePoints(
      points.size(), [&](std::size_t i) { return points[i].cast<double>(); }, path, limits);
}

}  // namespace strata::internal
