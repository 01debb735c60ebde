#include "strata/cloud_io.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <streambuf>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include <octomap/OcTree.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/common/io.h>
#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

namespace strata {
namespace {

template <typename... Args>
std::string Cat(const Args&... args) {
  std::ostringstream os;
  (os << ... << args);
  return os.str();
}

Error LoadError(std::string_view path, const std::string& problem) {
  return Error{ErrorCode::kMapLoadFailed, Cat(path, ": ", problem)};
}

Error TooBig(std::string_view path, const std::string& what, std::uint64_t limit,
             const char* field) {
  return Error{ErrorCode::kResourceExhausted,
               Cat(path, ": ", what, ", more than the limit of ", limit, " (CloudLoadLimits::",
                   field, ")")};
}

// File content echoed in a message: short and printable, since it may be binary garbage.
std::string Quote(std::string_view text) {
  std::string out = "'";
  for (char c : text.substr(0, 40)) out += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  return out + (text.size() > 40 ? "...'" : "'");
}

std::vector<std::string_view> Tokens(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t pos = 0;
  while ((pos = line.find_first_not_of(" \t\r", pos)) != std::string_view::npos) {
    const std::size_t end = std::min(line.find_first_of(" \t\r", pos), line.size());
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

// The next line of `bytes` from `*pos` (without its '\n'); advances *pos past it.
std::string_view NextLine(std::string_view bytes, std::size_t* pos) {
  const std::size_t eol = std::min(bytes.find('\n', *pos), bytes.size());
  std::string_view line = bytes.substr(*pos, eol - *pos);
  *pos = std::min(eol + 1, bytes.size());
  return line;
}

// Lets PCL and OctoMap parse the bytes already read and checked, without copying them and
// without a second read of a file that may have changed since.
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

// Shared by every loader and SanitizeCloud. `point_at(i)` yields point i in double precision,
// so an F8 coordinate of 1e300 is reported as out of range instead of becoming an infinity.
template <typename PointAt>
Expected<LoadedCloud> SanitizePoints(std::size_t count, const PointAt& point_at,
                                     std::string_view source, const CloudLoadLimits& limits) {
  if (count > limits.max_points) {
    return TooBig(source, Cat("holds ", count, " points"), limits.max_points, "max_points");
  }
  // Beyond float range a coordinate cannot be stored, whatever the configured limit.
  const double bound =
      std::min(limits.max_abs_coordinate_m, double{std::numeric_limits<float>::max()});
  LoadedCloud out;
  out.raw_point_count = count;
  out.points.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const Eigen::Vector3d p = point_at(i);
    if (!p.allFinite()) {
      ++out.dropped_nonfinite;
      continue;
    }
    if (p.cwiseAbs().maxCoeff() > bound) {
      return Error{ErrorCode::kInvalidInput,
                   Cat(source, ": point ", i, " at (", p.x(), ", ", p.y(), ", ", p.z(),
                       ") m lies beyond the ", limits.max_abs_coordinate_m,
                       " m coordinate limit; check the units (CloudLoadLimits::"
                       "max_abs_coordinate_m)")};
    }
    out.points.push_back(p.cast<float>());
  }
  return out;
}

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

Expected<std::string> ReadWholeFile(const std::string& path, const CloudLoadLimits& limits) {
  std::error_code ec;
  const std::filesystem::file_status status = std::filesystem::status(path, ec);
  if (status.type() == std::filesystem::file_type::not_found) {
    return LoadError(path, "file not found; check the path");
  }
  if (ec) return LoadError(path, "cannot access the file: " + ec.message());
  if (std::filesystem::is_directory(status)) {
    return LoadError(path, "is a directory, not a point-cloud file");
  }
  // A FIFO or device could block forever or never end.
  if (!std::filesystem::is_regular_file(status)) return LoadError(path, "is not a regular file");
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return LoadError(path, "cannot read the file size: " + ec.message());
  if (size == 0) return LoadError(path, "file is empty (0 bytes)");
  if (size > limits.max_file_bytes) {
    return TooBig(path, Cat("file is ", size, " bytes"), limits.max_file_bytes, "max_file_bytes");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return LoadError(path, "cannot open the file for reading; check its permissions");
  std::string bytes(size, '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size) {
    return LoadError(path, "could not read the whole file (did it change while loading?)");
  }
  return bytes;
}

void SilencePcl() {
  // PCL reports parse errors on the console; the library never prints, and every failure
  // becomes an Error with its own message instead.
  static std::once_flag once;
  std::call_once(once, [] { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); });
}

template <typename T>
double LoadScalar(const std::uint8_t* p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  return static_cast<double>(value);
}

// x, y and z of a PCLPointCloud2 whatever their numeric type; other fields are ignored.
class XyzReader {
 public:
  static Expected<XyzReader> Create(const pcl::PCLPointCloud2& cloud, std::size_t count,
                                    std::string_view path) {
    XyzReader reader;
    reader.data_ = cloud.data.data();
    reader.step_ = cloud.point_step;
    const char* names[3] = {"x", "y", "z"};
    for (int axis = 0; axis < 3; ++axis) {
      const auto field = std::find_if(cloud.fields.begin(), cloud.fields.end(),
                                      [&](const auto& f) { return f.name == names[axis]; });
      if (field == cloud.fields.end()) {
        std::string listed;
        for (const auto& f : cloud.fields) listed += (listed.empty() ? "" : ", ") + f.name;
        return LoadError(path, Cat("has no x, y and z fields (it has: ",
                                   listed.empty() ? "none" : listed,
                                   "); a map needs point coordinates"));
      }
      const std::size_t size = pcl::getFieldSize(field->datatype);
      if (size == 0 || field->count < 1 || field->offset + size > cloud.point_step) {
        return LoadError(path, Cat("field '", names[axis], "' has an unsupported type or layout"));
      }
      reader.offset_[axis] = field->offset;
      reader.type_[axis] = field->datatype;
    }
    if (cloud.point_step == 0 || cloud.data.size() / cloud.point_step < count) {
      return LoadError(path, Cat("the reader produced ", cloud.data.size(), " bytes for ", count,
                                 " points of ", cloud.point_step, " bytes (malformed file?)"));
    }
    return reader;
  }

  Eigen::Vector3d operator()(std::size_t i) const {
    Eigen::Vector3d p;
    for (int axis = 0; axis < 3; ++axis) p[axis] = Value(i * step_ + offset_[axis], type_[axis]);
    return p;
  }

 private:
  double Value(std::size_t at, std::uint8_t type) const {
    const std::uint8_t* p = data_ + at;
    switch (type) {
      case pcl::PCLPointField::INT8: return LoadScalar<std::int8_t>(p);
      case pcl::PCLPointField::UINT8: return LoadScalar<std::uint8_t>(p);
      case pcl::PCLPointField::INT16: return LoadScalar<std::int16_t>(p);
      case pcl::PCLPointField::UINT16: return LoadScalar<std::uint16_t>(p);
      case pcl::PCLPointField::INT32: return LoadScalar<std::int32_t>(p);
      case pcl::PCLPointField::UINT32: return LoadScalar<std::uint32_t>(p);
      case pcl::PCLPointField::INT64: return LoadScalar<std::int64_t>(p);
      case pcl::PCLPointField::UINT64: return LoadScalar<std::uint64_t>(p);
      case pcl::PCLPointField::FLOAT32: return LoadScalar<float>(p);
      case pcl::PCLPointField::FLOAT64: return LoadScalar<double>(p);
      default: return std::numeric_limits<double>::quiet_NaN();
    }
  }

  const std::uint8_t* data_ = nullptr;
  std::size_t step_ = 0;
  std::size_t offset_[3] = {};
  std::uint8_t type_[3] = {};
};

Expected<LoadedCloud> FromPcl(const pcl::PCLPointCloud2& cloud, std::size_t count,
                              const std::string& path, const CloudLoadLimits& limits) {
  Expected<XyzReader> reader = XyzReader::Create(cloud, count, path);
  if (!reader.ok()) return reader.error();
  return SanitizePoints(count, *reader, path, limits);
}

// ---- PCD ----------------------------------------------------------------------------------
// PCL parses the header and the body. It is only shielded from what it handles badly: it
// allocates POINTS x record bytes while reading the header, trusts the body to be as long as the
// header says, trusts the sizes in a compressed block, and rejects WIDTH 0 HEIGHT 0 headers.

Expected<LoadedCloud> LoadPcd(const std::string& path, std::string_view bytes,
                              const CloudLoadLimits& limits) {
  struct Line {
    std::string_view text;
    std::string_view keyword;
  };
  std::vector<Line> header;
  std::optional<std::uint64_t> width, height, points;
  std::string_view encoding;
  std::size_t body_offset = 0;
  bool found_data = false;
  for (std::size_t pos = 0; pos < bytes.size() && !found_data;) {
    const std::string_view text = NextLine(bytes, &pos);
    const std::vector<std::string_view> tokens = Tokens(text);
    if (tokens.empty() || tokens[0].front() == '#') continue;
    const std::string_view keyword = tokens[0];
    header.push_back({text, keyword});
    if (keyword == "DATA") {
      encoding = tokens.size() > 1 ? tokens[1] : "";
      body_offset = pos;
      found_data = true;
    } else if (keyword == "WIDTH" || keyword == "HEIGHT" || keyword == "POINTS") {
      const auto value = tokens.size() == 2 ? ParseCount(tokens[1]) : std::nullopt;
      if (!value) {
        return LoadError(path, Cat("header line ", Quote(text), " needs one count >= 0"));
      }
      (keyword == "WIDTH" ? width : keyword == "HEIGHT" ? height : points) = value;
    } else if (keyword != "VERSION" && keyword != "FIELDS" && keyword != "SIZE" &&
               keyword != "TYPE" && keyword != "COUNT" && keyword != "VIEWPOINT") {
      return LoadError(path, Cat("header line ", Quote(text),
                                 " is not a PCD header field; is this a PCD file?"));
    }
  }
  if (!found_data) return LoadError(path, "has no DATA line ending a PCD header; is this a PCD file?");
  const int data_type = encoding == "ascii" ? 0 : encoding == "binary" ? 1
                        : encoding == "binary_compressed" ? 2 : -1;
  if (data_type < 0) {
    return LoadError(path, Cat("DATA names encoding ", Quote(encoding),
                               "; expected ascii, binary or binary_compressed"));
  }
  if (!points) return LoadError(path, "header has no POINTS line");
  const std::uint64_t n = *points;
  if (n == 0) return LoadError(path, "contains no points (POINTS 0)");
  if (n > limits.max_points) {
    return TooBig(path, Cat("header declares ", n, " points"), limits.max_points, "max_points");
  }
  if (n > std::numeric_limits<std::uint32_t>::max()) {
    return LoadError(path, Cat("header declares ", n, " points, more than a PCD file can hold"));
  }
  // Real-world exporters write WIDTH 0 HEIGHT 0 with POINTS set; PCL rejects that, so PCL is
  // given WIDTH = POINTS, HEIGHT 1 instead. Any other disagreement is the file's fault.
  bool fix_dimensions = false;
  if (width || height) {
    const std::uint64_t w = width.value_or(0), h = height.value_or(1);
    if (w == 0) {
      fix_dimensions = true;
    } else if (h == 0 || w > n / h || w * h != n) {
      return LoadError(path, Cat("header says WIDTH ", w, " x HEIGHT ", h, " but POINTS ", n,
                                 "; fix WIDTH and HEIGHT"));
    }
  }

  // First let PCL read the header without WIDTH/HEIGHT/POINTS: that yields the record layout
  // without allocating anything, so the body can be checked before PCL sizes its buffer.
  const auto build_header = [&](bool with_size) {
    std::string text;
    for (const Line& line : header) {
      const bool dimensions = line.keyword == "WIDTH" || line.keyword == "HEIGHT";
      const bool count = line.keyword == "POINTS";
      if (!with_size && (dimensions || count)) continue;
      if (with_size && fix_dimensions && dimensions) continue;
      if (with_size && fix_dimensions && count) text += Cat("WIDTH ", n, "\nHEIGHT 1\n");
      text.append(line.text).append("\n");
    }
    return text;
  };
  pcl::PCDReader reader;
  pcl::PCLPointCloud2 cloud;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0, pcl_data_type = 0;
  unsigned int unused_offset = 0;
  const auto read_header = [&](const std::string& text) {
    std::istringstream in(text);
    return reader.readHeader(in, cloud, origin, orientation, version, pcl_data_type,
                             unused_offset) == 0;
  };
  if (!read_header(build_header(false))) {
    return LoadError(path, "PCL rejected the header; check FIELDS, SIZE, TYPE and COUNT");
  }
  std::uint64_t record = 0, values_per_point = 0;
  for (const auto& field : cloud.fields) {
    record += std::uint64_t{field.count} * pcl::getFieldSize(field.datatype);
    values_per_point += field.count;
  }
  if (cloud.fields.empty() || record == 0 || record != cloud.point_step) {
    return LoadError(path, "header's FIELDS, SIZE, TYPE and COUNT lines are missing or disagree");
  }
  if (Expected<XyzReader> xyz = XyzReader::Create(cloud, 0, path); !xyz.ok()) return xyz.error();

  const std::string_view body = bytes.substr(body_offset);
  const std::uint64_t need = n * record;
  const std::string promise = Cat("header promises ", n, " points of ", record, " bytes");
  if (data_type == 1 && need > body.size()) {
    return LoadError(path, Cat(promise, " (", need, " bytes) but the body holds ", body.size(),
                               " bytes (truncated file?)"));
  }
  if (data_type == 2) {
    std::uint32_t packed = 0, unpacked = 0;
    if (body.size() < 8) {
      return LoadError(path, "binary_compressed body is shorter than its 8-byte size prefix "
                             "(truncated file?)");
    }
    std::memcpy(&packed, body.data(), 4);
    std::memcpy(&unpacked, body.data() + 4, 4);
    if (unpacked != need) {
      return LoadError(path, Cat("compressed block says it unpacks to ", unpacked, " bytes but ",
                                 promise, " = ", need, " (corrupt file?)"));
    }
    if (packed > body.size() - 8) {
      return LoadError(path, Cat("compressed block of ", packed, " bytes runs past the end of ",
                                 "the file, which holds ", body.size() - 8, " (truncated file?)"));
    }
  }
  if (data_type == 0) {
    // Count the data lines first: PCL would allocate for POINTS before noticing a short body,
    // and it silently turns a line with the wrong number of values into a point at the origin.
    std::uint64_t lines = 0;
    for (std::size_t pos = 0; pos < body.size() && lines < n;) {
      const std::string_view text = NextLine(body, &pos);
      if (text.empty()) continue;
      const std::size_t values = Tokens(text).size();
      if (values != values_per_point) {
        return LoadError(path, Cat("data line ", lines + 1, " has ", values, " values but the ",
                                   "fields need ", values_per_point, " (malformed file?)"));
      }
      ++lines;
    }
    if (lines < n) {
      return LoadError(path, Cat("header promises ", n, " points but the body holds ", lines,
                                 " lines of values (truncated file?)"));
    }
  }

  if (!read_header(build_header(true)) || std::uint64_t{cloud.width} * cloud.height != n ||
      cloud.data.size() != need) {
    return LoadError(path, "PCL rejected the header; check the order of its lines");
  }
  int result = -1;
  if (data_type == 0) {
    MemoryStreambuf buffer(body);
    std::istream in(&buffer);
    result = reader.readBodyASCII(in, cloud, version);
  } else if (body_offset <= std::numeric_limits<unsigned int>::max()) {
    result = reader.readBodyBinary(reinterpret_cast<const unsigned char*>(bytes.data()), cloud,
                                   version, data_type == 2,
                                   static_cast<unsigned int>(body_offset));
  }
  if (result != 0) {
    return LoadError(path, Cat("PCL could not decode the ", encoding, " body (corrupt ",
                               data_type == 2 ? "compressed block" : "data", "?)"));
  }
  return FromPcl(cloud, n, path, limits);
}

// ---- PLY ----------------------------------------------------------------------------------
// PCL's PLY reader sizes its buffer from the header's vertex count (or obj_info dimensions)
// and reads the file itself, so the header is checked against the limits and the file size
// first. PCL then parses the whole file.

std::size_t PlyTypeSize(std::string_view type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "int32" || type == "uint32" || type == "float" ||
      type == "float32") {
    return 4;
  }
  if (type == "double" || type == "float64") return 8;
  return 0;
}

Expected<LoadedCloud> LoadPly(const std::string& path, std::string_view bytes,
                              const CloudLoadLimits& limits) {
  std::size_t pos = 0;
  if (Tokens(NextLine(bytes, &pos)) != std::vector<std::string_view>{"ply"}) {
    return LoadError(path, "does not start with 'ply'; is this a PLY file?");
  }
  bool ascii = false, found_end = false, in_vertex = false;
  std::optional<std::uint64_t> vertices;
  std::uint64_t min_body = 0, element_count = 0, grid = 1;
  unsigned vertex_xyz = 0;  // Bit per axis found.
  while (pos < bytes.size() && !found_end) {
    const std::string_view text = NextLine(bytes, &pos);
    const std::vector<std::string_view> t = Tokens(text);
    if (t.empty() || t[0] == "comment") continue;
    const auto bad_line = [&] {
      return LoadError(path, Cat("PLY header line ", Quote(text), " is malformed"));
    };
    if (t[0] == "end_header") {
      found_end = true;
    } else if (t[0] == "format") {
      if (t.size() < 2) return bad_line();
      ascii = t[1] == "ascii";
    } else if (t[0] == "element") {
      const auto count = t.size() == 3 ? ParseCount(t[2]) : std::nullopt;
      if (!count) return bad_line();
      in_vertex = t[1] == "vertex";
      if (in_vertex && *count > limits.max_points) {
        return TooBig(path, Cat("header declares ", *count, " vertices"), limits.max_points,
                      "max_points");
      }
      if (*count > bytes.size()) {  // Keeps min_body from overflowing; each takes >= 1 byte.
        return LoadError(path, Cat("header declares ", *count, " ", Quote(t[1]), " elements in a ",
                                   bytes.size(), "-byte file (truncated file?)"));
      }
      element_count = *count;
      if (in_vertex) vertices = count;
    } else if (t[0] == "property") {
      const bool list = t.size() == 5 && t[1] == "list";
      const std::size_t size = PlyTypeSize(t[1 + list]);
      if ((t.size() != 3 && !list) || size == 0 || (list && PlyTypeSize(t[3]) == 0)) {
        return bad_line();
      }
      // The least body an element can take: one byte and a separator per ASCII value, or the
      // binary size (a list at least its length field).
      min_body += element_count * (ascii ? 2 : size);
      if (in_vertex && !list && t[2].size() == 1 && t[2][0] >= 'x' && t[2][0] <= 'z') {
        vertex_xyz |= 1u << (t[2][0] - 'x');
      }
    } else if (t[0] == "obj_info") {
      // PCL sizes the cloud as num_cols x num_rows when these are given.
      if (t.size() >= 3 && (t[1] == "num_cols" || t[1] == "num_rows")) {
        const auto value = ParseCount(t[2]);
        if (!value || *value > limits.max_points) return bad_line();
        grid *= *value;
      }
    } else {
      return bad_line();
    }
  }
  if (!found_end) return LoadError(path, "has no end_header line; is this a PLY file?");
  if (!vertices) return LoadError(path, "has no 'element vertex'; a map needs vertices");
  if (vertex_xyz != 7u) {
    return LoadError(path, "its vertex element lacks x, y and z properties; a map needs them");
  }
  if (grid > limits.max_points) {
    return TooBig(path, Cat("obj_info declares ", grid, " points"), limits.max_points,
                  "max_points");
  }
  const std::uint64_t body = bytes.size() - pos;
  if (min_body > body + (ascii ? 1 : 0)) {
    return LoadError(path, Cat("header promises at least ", min_body, " bytes of data but the ",
                               "body holds ", body, " bytes (truncated file?)"));
  }

  pcl::PLYReader reader;
  pcl::PCLPointCloud2 cloud;
  if (reader.read(path, cloud) != 0) {
    return LoadError(path, "PCL could not parse the PLY data (malformed or truncated file?)");
  }
  // A range_grid element makes PCL remap the vertices; otherwise there is one per vertex.
  const std::size_t count = cloud.point_step == 0 ? 0 : cloud.data.size() / cloud.point_step;
  return FromPcl(cloud, count, path, limits);
}

// ---- OctoMap ------------------------------------------------------------------------------
// OctoMap neither bounds the tree depth nor notices the end of its stream (it then decodes
// uninitialised bytes and may recurse without end), so the node structure is walked here first,
// exactly as OctoMap will read it, and only a well-formed tree is handed to it.

constexpr unsigned kOctreeDepth = 16;  // OcTree's fixed depth.

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
    return LoadError(path, Cat("does not start with '", want, "'; is this an OctoMap ",
                               binary ? ".bt" : ".ot", " file? (legacy .bt files need ",
                               "convert_octree)"));
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
      const std::string value(token());
      char* end = nullptr;
      header.resolution_m = std::strtod(value.c_str(), &end);
      if (end != value.c_str() + value.size()) header.resolution_m = 0.0;
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
  std::uint64_t occupied_voxels = 0;  // Finest-resolution voxels inside occupied leaves.
  const char* problem = nullptr;

  void AddOccupied(unsigned depth) {
    const std::uint64_t voxels = std::uint64_t{1} << (3 * (kOctreeDepth - depth));
    occupied_voxels = std::min(occupied_voxels + voxels, std::uint64_t{1} << 62);
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
  // The nodes and, once pruned blocks are expanded, the voxels are what cost memory.
  if (walk.nodes > limits.max_points || walk.occupied_voxels > limits.max_points) {
    return TooBig(path, Cat("OctoMap holds ", walk.nodes, " nodes and ", walk.occupied_voxels,
                            " occupied voxels"),
                  limits.max_points, "max_points");
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
  // block's surfaces, so every finest-resolution voxel in it becomes a point.
  PointCloud points;
  points.reserve(walk.occupied_voxels);
  const double resolution = tree->getResolution();
  for (auto it = tree->begin_leafs(), end = tree->end_leafs(); it != end; ++it) {
    if (!tree->isNodeOccupied(*it)) continue;
    const int per_axis = 1 << (tree->getTreeDepth() - it.getDepth());
    const octomap::point3d centre = it.getCoordinate();
    const Eigen::Vector3d corner =
        Eigen::Vector3d(centre.x(), centre.y(), centre.z()).array() - 0.5 * it.getSize();
    if (points.size() + std::uint64_t(per_axis) * per_axis * per_axis > limits.max_points) {
      return TooBig(path, "OctoMap expands to more voxels", limits.max_points, "max_points");
    }
    for (int i = 0; i < per_axis; ++i) {
      for (int j = 0; j < per_axis; ++j) {
        for (int k = 0; k < per_axis; ++k) {
          const Eigen::Vector3d offset(i + 0.5, j + 0.5, k + 0.5);
          points.push_back((corner + resolution * offset).cast<float>());
        }
      }
    }
  }
  return SanitizePoints(
      points.size(), [&](std::size_t i) { return points[i].cast<double>(); }, path, limits);
}

}  // namespace

Expected<LoadedCloud> LoadPointCloud(const std::string& path, const CloudLoadLimits& limits) {
  if (Status status = CheckLimits(limits); !status.ok()) return status.error();
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension != ".pcd" && extension != ".ply" && extension != ".bt" && extension != ".ot") {
    return LoadError(path, Cat("unsupported extension ", Quote(extension),
                               "; supported: .pcd, .ply, .bt, .ot"));
  }
  // The readers are third-party code: whatever they throw becomes an error here.
  try {
    Expected<std::string> bytes = ReadWholeFile(path, limits);
    if (!bytes.ok()) return bytes.error();
    SilencePcl();
    Expected<LoadedCloud> cloud =
        extension == ".pcd"   ? LoadPcd(path, *bytes, limits)
        : extension == ".ply" ? LoadPly(path, *bytes, limits)
                              : LoadOctree(path, *bytes, limits, extension == ".bt");
    if (cloud.ok() && cloud->points.empty()) {
      return LoadError(path, cloud->raw_point_count == 0
                                 ? std::string("contains no points")
                                 : Cat("contains no finite points (all ", cloud->raw_point_count,
                                       " have NaN/Inf coordinates)"));
    }
    return cloud;
  } catch (const std::bad_alloc&) {
    return Error{ErrorCode::kResourceExhausted,
                 Cat(path, ": ran out of memory while loading; lower CloudLoadLimits")};
  } catch (const std::exception& e) {
    return LoadError(path, Cat("could not be read: ", e.what()));
  } catch (...) {
    return LoadError(path, "could not be read (the reader failed)");
  }
}

Expected<LoadedCloud> SanitizeCloud(PointCloud raw, const CloudLoadLimits& limits) {
  if (Status status = CheckLimits(limits); !status.ok()) return status.error();
  Expected<LoadedCloud> cloud = SanitizePoints(
      raw.size(), [&](std::size_t i) { return raw[i].cast<double>(); }, "cloud", limits);
  if (cloud.ok() && cloud->points.empty()) {
    return Error{ErrorCode::kInvalidInput,
                 Cat("cloud contains no finite points (", raw.size(), " given)")};
  }
  return cloud;
}

}  // namespace strata
