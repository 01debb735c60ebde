// PCD and PLY loading through PCL (see cloud_io_internal.hpp).
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <istream>
#include <limits>
#include <mutex>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include <pcl/PCLPointCloud2.h>
#include <pcl/common/io.h>
#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "io/cloud_io_internal.hpp"
#include "pcl_quiet_internal.hpp"

namespace strata::internal {
namespace {

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
        return LoadError(path,
                         Cat("has no x, y and z fields (it has: ", listed.empty() ? "none" : listed,
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

enum class PcdEncoding { kAscii = 0, kBinary = 1, kBinaryCompressed = 2 };  // PCL's data_type.

// The header lines (comments and blank lines left out) and the values this file checks itself.
struct PcdHeader {
  struct Line {
    std::string_view text;
    std::string_view keyword;
  };
  std::vector<Line> lines;
  std::optional<std::uint64_t> width, height, points;
  PcdEncoding encoding = PcdEncoding::kAscii;
  std::string_view encoding_name;
  std::size_t body_offset = 0;

  // The header as PCL is to see it. PCL allocates POINTS x record bytes as it reads the POINTS
  // line, so `layout_only` leaves out WIDTH, HEIGHT and POINTS: that yields the record layout
  // and nothing else. `fix_dimensions` puts WIDTH = POINTS, HEIGHT 1 in place of the file's.
  std::string Text(bool layout_only, bool fix_dimensions) const {
    std::string text;
    for (const Line& line : lines) {
      const bool dimensions = line.keyword == "WIDTH" || line.keyword == "HEIGHT";
      const bool count = line.keyword == "POINTS";
      if (layout_only && (dimensions || count)) continue;
      if (fix_dimensions && dimensions) continue;
      if (fix_dimensions && count) text += Cat("WIDTH ", *points, "\nHEIGHT 1\n");
      text.append(line.text).append("\n");
    }
    return text;
  }
};

// Finds the header's end and the counts in it; the rest of the header is left to PCL.
Expected<PcdHeader> ScanPcdHeader(const std::string& path, std::string_view bytes) {
  PcdHeader header;
  bool found_data = false;
  for (std::size_t pos = 0; pos < bytes.size() && !found_data;) {
    const std::string_view text = NextLine(bytes, &pos);
    const std::vector<std::string_view> tokens = Tokens(text);
    if (tokens.empty() || tokens[0].front() == '#') continue;
    const std::string_view keyword = tokens[0];
    // PCL applies each line as it comes: a second COUNT after POINTS re-sizes the fields of a
    // record PCL has already allocated POINTS of (a fuzzed 188-byte file asked for 8 GiB).
    for (const PcdHeader::Line& seen : header.lines) {
      if (seen.keyword == keyword) {
        return LoadError(path, Cat("header line ", Quote(text), " repeats ", keyword,
                                   "; a PCD header has each field once"));
      }
    }
    header.lines.push_back({text, keyword});
    if (keyword == "DATA") {
      header.encoding_name = tokens.size() > 1 ? tokens[1] : "";
      header.body_offset = pos;
      found_data = true;
    } else if (keyword == "WIDTH" || keyword == "HEIGHT" || keyword == "POINTS") {
      const auto value = tokens.size() == 2 ? ParseCount(tokens[1]) : std::nullopt;
      if (!value) {
        return LoadError(path, Cat("header line ", Quote(text), " needs one count >= 0"));
      }
      (keyword == "WIDTH"    ? header.width
       : keyword == "HEIGHT" ? header.height
                             : header.points) = value;
    } else if (keyword != "VERSION" && keyword != "FIELDS" && keyword != "SIZE" &&
               keyword != "TYPE" && keyword != "COUNT" && keyword != "VIEWPOINT") {
      return LoadError(path, Cat("header line ", Quote(text),
                                 " is not a PCD header field; is this a PCD file?"));
    }
  }
  if (!found_data) {
    return LoadError(path, "has no DATA line ending a PCD header; is this a PCD file?");
  }
  if (header.encoding_name == "ascii") {
    header.encoding = PcdEncoding::kAscii;
  } else if (header.encoding_name == "binary") {
    header.encoding = PcdEncoding::kBinary;
  } else if (header.encoding_name == "binary_compressed") {
    header.encoding = PcdEncoding::kBinaryCompressed;
  } else {
    return LoadError(path, Cat("DATA names encoding ", Quote(header.encoding_name),
                               "; expected ascii, binary or binary_compressed"));
  }
  if (!header.points) return LoadError(path, "header has no POINTS line");
  return header;
}

// Checks that the body holds the `n` points of `record` bytes (`values` numbers in ASCII) the
// header promises, before PCL allocates for them and trusts them to be there.
Status CheckPcdBody(const std::string& path, PcdEncoding encoding, std::string_view body,
                    std::uint64_t n, std::uint64_t record, std::uint64_t values) {
  const std::uint64_t need = n * record;
  const std::string promise = Cat("header promises ", n, " points of ", record, " bytes");
  switch (encoding) {
    case PcdEncoding::kBinary:
      if (need > body.size()) {
        return LoadError(path, Cat(promise, " (", need, " bytes) but the body holds ", body.size(),
                                   " bytes (truncated file?)"));
      }
      return Status::Ok();
    case PcdEncoding::kBinaryCompressed: {
      // PCL resizes its buffer to whatever the block claims and reads as far as it says.
      if (body.size() < 8) {
        return LoadError(path,
                         "binary_compressed body is shorter than its 8-byte size prefix "
                         "(truncated file?)");
      }
      std::uint32_t packed = 0, unpacked = 0;
      std::memcpy(&packed, body.data(), 4);
      std::memcpy(&unpacked, body.data() + 4, 4);
      if (unpacked != need) {
        return LoadError(path, Cat("compressed block says it unpacks to ", unpacked, " bytes but ",
                                   promise, " = ", need, " (corrupt file?)"));
      }
      if (packed > body.size() - 8) {
        return LoadError(path,
                         Cat("compressed block of ", packed, " bytes runs past the end of ",
                             "the file, which holds ", body.size() - 8, " (truncated file?)"));
      }
      return Status::Ok();
    }
    case PcdEncoding::kAscii: {
      // PCL would silently turn a line with the wrong number of values into a point at the
      // origin, and find a short body only after allocating for all of it.
      std::uint64_t lines = 0;
      for (std::size_t pos = 0; pos < body.size() && lines < n;) {
        const std::string_view text = NextLine(body, &pos);
        if (text.empty()) continue;
        const std::size_t found = Tokens(text).size();
        if (found != values) {
          return LoadError(path, Cat("data line ", lines + 1, " has ", found, " values but the ",
                                     "fields need ", values, " (malformed file?)"));
        }
        ++lines;
      }
      if (lines < n) {
        return LoadError(path, Cat("header promises ", n, " points but the body holds ", lines,
                                   " lines of values (truncated file?)"));
      }
      return Status::Ok();
    }
  }
  return Status::Ok();
}

}  // namespace

// PCL parses the header and the body; it is only shielded from what it handles badly (see
// PcdHeader::Text and CheckPcdBody) and given WIDTH = POINTS where the file says WIDTH 0.
Expected<LoadedCloud> LoadPcd(const std::string& path, std::string_view bytes,
                              const CloudLoadLimits& limits) {
  SilencePclConsole();
  Expected<PcdHeader> header = ScanPcdHeader(path, bytes);
  if (!header.ok()) return header.error();
  const std::uint64_t n = *header->points;
  if (n == 0) return LoadError(path, "contains no points (POINTS 0)");
  if (n > limits.max_points) {
    return TooBig(path, Cat("header declares ", n, " points"), limits.max_points, "max_points");
  }
  if (n > std::numeric_limits<std::uint32_t>::max()) {
    return LoadError(path, Cat("header declares ", n, " points, more than a PCD file can hold"));
  }
  // Real-world exporters write WIDTH 0 HEIGHT 0 with POINTS set, which PCL rejects. Any other
  // disagreement is the file's fault.
  bool fix_dimensions = false;
  if (header->width || header->height) {
    const std::uint64_t w = header->width.value_or(0), h = header->height.value_or(1);
    if (w == 0) {
      fix_dimensions = true;
    } else if (h == 0 || w > n / h || w * h != n) {
      return LoadError(path, Cat("header says WIDTH ", w, " x HEIGHT ", h, " but POINTS ", n,
                                 "; fix WIDTH and HEIGHT"));
    }
  }

  pcl::PCDReader reader;
  pcl::PCLPointCloud2 cloud;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  int version = 0, data_type = 0;
  unsigned int header_end = 0;
  const auto read_header = [&](const std::string& text) {
    std::istringstream in(text);
    return reader.readHeader(in, cloud, origin, orientation, version, data_type, header_end) == 0;
  };
  if (!read_header(header->Text(/*layout_only=*/true, false))) {
    return LoadError(path, "PCL rejected the header; check FIELDS, SIZE, TYPE and COUNT");
  }
  std::uint64_t record = 0, values = 0;
  for (const auto& field : cloud.fields) {
    record += std::uint64_t{field.count} * pcl::getFieldSize(field.datatype);
    values += field.count;
  }
  if (cloud.fields.empty() || record == 0 || record != cloud.point_step) {
    return LoadError(path, "header's FIELDS, SIZE, TYPE and COUNT lines are missing or disagree");
  }
  if (Expected<XyzReader> xyz = XyzReader::Create(cloud, 0, path); !xyz.ok()) return xyz.error();
  const std::string_view body = bytes.substr(header->body_offset);
  if (Status status = CheckPcdBody(path, header->encoding, body, n, record, values); !status.ok()) {
    return status.error();
  }

  if (!read_header(header->Text(false, fix_dimensions)) ||
      std::uint64_t{cloud.width} * cloud.height != n || cloud.data.size() != n * record) {
    return LoadError(path, "PCL rejected the header; check the order of its lines");
  }
  int result = -1;
  if (header->encoding == PcdEncoding::kAscii) {
    MemoryStreambuf buffer(body);
    std::istream in(&buffer);
    result = reader.readBodyASCII(in, cloud, version);
  } else if (header->body_offset <= std::numeric_limits<unsigned int>::max()) {
    result = reader.readBodyBinary(reinterpret_cast<const unsigned char*>(bytes.data()), cloud,
                                   version, header->encoding == PcdEncoding::kBinaryCompressed,
                                   static_cast<unsigned int>(header->body_offset));
  }
  if (result != 0) {
    return LoadError(
        path, Cat("PCL could not decode the ", header->encoding_name, " body (",
                  header->encoding == PcdEncoding::kBinaryCompressed ? "corrupt compressed block?)"
                                                                     : "corrupt data?)"));
  }
  return FromPcl(cloud, n, path, limits);
}

namespace {

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

}  // namespace

// PCL's PLY reader sizes its buffer from the header's vertex count (or obj_info dimensions)
// and reads the file itself, so the header is checked against the limits and the file size
// first. PCL then parses the whole file.
Expected<LoadedCloud> LoadPly(const std::string& path, std::string_view bytes,
                              const CloudLoadLimits& limits) {
  SilencePclConsole();
  std::size_t pos = 0;
  if (Tokens(NextLine(bytes, &pos)) != std::vector<std::string_view>{"ply"}) {
    return LoadError(path, "does not start with 'ply'; is this a PLY file?");
  }
  bool ascii = false, found_end = false, in_vertex = false, range_grid = false;
  std::optional<std::uint64_t> vertices, grid_cols, grid_rows;
  std::uint64_t min_body = 0, element_count = 0;
  unsigned vertex_xyz = 0;  // Bit per axis found.
  while (pos < bytes.size() && !found_end) {
    const std::string_view text = NextLine(bytes, &pos);
    const std::vector<std::string_view> t = Tokens(text);
    if (t.empty() || t[0] == "comment") continue;
    const auto bad_line = [&] {
      return LoadError(path, Cat("PLY header line ", Quote(text), " is malformed"));
    };
    // PCL splits some header lines at whitespace and asserts that the first piece is the
    // keyword (an abort of the whole process in Debian's build), so a keyword must start
    // its line: no space, tab or carriage return before it.
    if (kWordSeparators.find(text.front()) != std::string_view::npos) {
      return LoadError(path, Cat("PLY header line ", Quote(text),
                                 " starts with whitespace; a header keyword must start its line"));
    }
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
      range_grid = range_grid || t[1] == "range_grid";
    } else if (t[0] == "property") {
      const bool list = t.size() == 5 && t[1] == "list";
      if (t.size() != 3 && !list) return bad_line();
      const std::size_t size = PlyTypeSize(t[1 + list]);
      if (size == 0 || (list && PlyTypeSize(t[3]) == 0)) return bad_line();
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
        (t[1] == "num_cols" ? grid_cols : grid_rows) = value;
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
  // PCL writes vertex k at index k of its num_cols x num_rows cloud and asserts (aborting the
  // process) past its end: the grid must hold the vertices exactly.
  const std::uint64_t cells = grid_cols.value_or(1) * grid_rows.value_or(1);
  if (range_grid && cells > limits.max_points) {
    return TooBig(path, Cat("obj_info declares ", cells, " points"), limits.max_points,
                  "max_points");
  }
  if ((grid_cols || grid_rows) && !range_grid) {
    if (!grid_cols || !grid_rows || cells != *vertices) {
      return LoadError(path, Cat("obj_info num_cols × num_rows (", grid_cols.value_or(0), " × ",
                                 grid_rows.value_or(0), ") must equal the ", *vertices,
                                 " vertices; give both or neither"));
    }
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
  // A range_grid element makes PCL lay the vertices out on its grid; otherwise PCL sizes the
  // cloud from obj_info or camera dimensions when present, which must match the vertex count.
  const std::size_t count = cloud.point_step == 0 ? 0 : cloud.data.size() / cloud.point_step;
  if (!range_grid && count != *vertices) {
    return LoadError(path, Cat("its obj_info or camera dimensions give ", count,
                               " points but it has ", *vertices, " vertices"));
  }
  return FromPcl(cloud, count, path, limits);
}

}  // namespace strata::internal

namespace strata {

Status SavePcd(const PointCloud& cloud, const std::string& path) {
  if (cloud.empty()) {
    return Error{ErrorCode::kInvalidInput, path + ": cannot write an empty cloud as PCD"};
  }
  internal::SilencePclConsole();
  pcl::PointCloud<pcl::PointXYZ> out;
  out.resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    out[i] = pcl::PointXYZ(cloud[i].x(), cloud[i].y(), cloud[i].z());
  }
  out.width = static_cast<std::uint32_t>(cloud.size());
  out.height = 1;
  out.is_dense = std::all_of(cloud.begin(), cloud.end(),
                             [](const Eigen::Vector3f& p) { return p.allFinite(); });
  try {
    if (pcl::io::savePCDFileBinary(path, out) != 0) {
      return Error{ErrorCode::kInvalidInput,
                   path + ": cannot write the PCD file (missing directory or no permission?)"};
    }
  } catch (const std::exception& e) {
    return Error{ErrorCode::kInvalidInput, path + ": cannot write the PCD file: " + e.what()};
  }
  return Status::Ok();
}

}  // namespace strata
