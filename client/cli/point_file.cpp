#include "point_file.hpp"

#include <bit>
#include <cstring>
#include <filesystem>
#include <limits>
#include <sstream>

#include <fmt/format.h>

#include "context.hpp"

namespace strata::cli {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the upload encoding and binary PCD are little-endian");

void AppendPoint(float x, float y, float z, std::string* chunk) {
  const float xyz[3] = {x, y, z};
  chunk->append(reinterpret_cast<const char*>(xyz), sizeof(xyz));
}

std::vector<std::string> Tokens(const std::string& line) {
  std::string spaced = line;
  for (char& c : spaced) {
    if (c == ',' || c == '\t' || c == '\r') c = ' ';
  }
  std::istringstream stream(spaced);
  std::vector<std::string> tokens;
  for (std::string token; stream >> token;) tokens.push_back(token);
  return tokens;
}

}  // namespace

std::optional<PointFileFormat> ParsePointFileFormat(const std::string& name) {
  if (name == "pcd") return PointFileFormat::kPcd;
  if (name == "xyz") return PointFileFormat::kText;
  if (name == "raw") return PointFileFormat::kRawF32;
  return std::nullopt;
}

std::optional<PointFileFormat> GuessPointFileFormat(const std::string& path) {
  const std::string extension = std::filesystem::path(path).extension().string();
  if (extension == ".pcd") return PointFileFormat::kPcd;
  if (extension == ".xyz" || extension == ".txt" || extension == ".csv")
    return PointFileFormat::kText;
  if (extension == ".bin" || extension == ".raw" || extension == ".f32") {
    return PointFileFormat::kRawF32;
  }
  return std::nullopt;
}

PointFileReader::PointFileReader(const std::string& path, PointFileFormat format)
    : path_(path), format_(format), file_(path, std::ios::binary) {
  if (!file_) throw UsageError("cannot read \"" + path + "\"");
  if (format_ == PointFileFormat::kPcd) {
    ReadPcdHeader();
  } else if (format_ == PointFileFormat::kRawF32) {
    const std::uintmax_t bytes = std::filesystem::file_size(path);
    if (bytes % 12 != 0) {
      throw UsageError(fmt::format(
          "\"{}\" has {} bytes, not a multiple of 12 (raw float32 x, y, z points)", path, bytes));
    }
    point_count_ = bytes / 12;
  }
}

void PointFileReader::ReadPcdHeader() {
  std::vector<std::string> fields, types;
  std::vector<int> sizes, counts;
  std::uint64_t width = 0, height = 1;
  bool have_points = false;
  for (std::string line; std::getline(file_, line);) {
    ++line_;
    const std::vector<std::string> tokens = Tokens(line);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    const std::string& key = tokens[0];
    const std::vector<std::string> values(tokens.begin() + 1, tokens.end());
    try {
      if (key == "FIELDS") fields = values;
      if (key == "TYPE") types = values;
      if (key == "SIZE")
        for (const auto& v : values) sizes.push_back(std::stoi(v));
      if (key == "COUNT")
        for (const auto& v : values) counts.push_back(std::stoi(v));
      if (key == "WIDTH" && !values.empty()) width = std::stoull(values[0]);
      if (key == "HEIGHT" && !values.empty()) height = std::stoull(values[0]);
      if (key == "POINTS" && !values.empty()) {
        point_count_ = std::stoull(values[0]);
        have_points = true;
      }
    } catch (const std::exception&) {
      throw UsageError(fmt::format("\"{}\" line {}: bad PCD header value", path_, line_));
    }
    if (key != "DATA") continue;
    if (values.empty() || (values[0] != "ascii" && values[0] != "binary")) {
      throw UsageError("\"" + path_ + "\": PCD DATA " + (values.empty() ? "" : values[0]) +
                       " is not supported (ascii or binary); convert it, or put the file under "
                       "the server's --map-root and use `strata maps create --file`");
    }
    pcd_binary_ = values[0] == "binary";
    if (counts.empty()) counts.assign(fields.size(), 1);
    if (sizes.size() != fields.size() || types.size() != fields.size() ||
        counts.size() != fields.size()) {
      throw UsageError("\"" + path_ + "\": PCD FIELDS, SIZE, TYPE and COUNT disagree in length");
    }
    if (!have_points) point_count_ = width * height;
    std::size_t offset = 0;
    bool found[3] = {false, false, false};
    for (std::size_t f = 0; f < fields.size(); ++f) {
      const int axis = fields[f] == "x" ? 0 : fields[f] == "y" ? 1 : fields[f] == "z" ? 2 : -1;
      if (axis >= 0) {
        if (types[f] != "F" || (sizes[f] != 4 && sizes[f] != 8) || counts[f] != 1) {
          throw UsageError("\"" + path_ + "\": PCD field " + fields[f] +
                           " must be TYPE F, SIZE 4 or 8, COUNT 1");
        }
        xyz_[axis] = Field{offset, sizes[f]};
        found[axis] = true;
      }
      offset += pcd_binary_ ? static_cast<std::size_t>(sizes[f]) * counts[f]
                            : static_cast<std::size_t>(counts[f]);
    }
    if (!found[0] || !found[1] || !found[2]) {
      throw UsageError("\"" + path_ + "\": PCD has no x, y and z fields");
    }
    record_bytes_ = offset;  // Bytes per binary record, or tokens per ascii line.
    return;
  }
  throw UsageError("\"" + path_ + "\": no PCD DATA line (is it a PCD file?)");
}

bool PointFileReader::Next(std::size_t max_points, std::string* chunk) {
  chunk->clear();
  switch (format_) {
    case PointFileFormat::kPcd:
      return pcd_binary_ ? NextBinary(max_points, chunk) : NextText(max_points, chunk, true);
    case PointFileFormat::kText: return NextText(max_points, chunk, false);
    case PointFileFormat::kRawF32: return NextBinary(max_points, chunk);
  }
  return false;
}

bool PointFileReader::NextBinary(std::size_t max_points, std::string* chunk) {
  const std::uint64_t left = point_count_ - points_read_;
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(left, max_points));
  if (n == 0) return false;
  std::string records(n * record_bytes_, '\0');
  file_.read(records.data(), static_cast<std::streamsize>(records.size()));
  if (static_cast<std::size_t>(file_.gcount()) != records.size()) {
    throw UsageError(fmt::format("\"{}\" ends after {} of {} points", path_,
                                 points_read_ + file_.gcount() / record_bytes_, point_count_));
  }
  if (format_ == PointFileFormat::kRawF32) {
    *chunk = std::move(records);
  } else {
    chunk->reserve(n * 12);
    for (std::size_t i = 0; i < n; ++i) {
      float xyz[3];
      for (int a = 0; a < 3; ++a) {
        const char* source = records.data() + i * record_bytes_ + xyz_[a].offset;
        if (xyz_[a].size == 4) {
          std::memcpy(&xyz[a], source, 4);
        } else {
          double value;
          std::memcpy(&value, source, 8);
          xyz[a] = static_cast<float>(value);
        }
      }
      AppendPoint(xyz[0], xyz[1], xyz[2], chunk);
    }
  }
  points_read_ += n;
  return true;
}

bool PointFileReader::NextText(std::size_t max_points, std::string* chunk, bool pcd_ascii) {
  std::size_t n = 0;
  for (std::string line; n < max_points && std::getline(file_, line);) {
    ++line_;
    const std::vector<std::string> tokens = Tokens(line);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    const std::size_t needed = pcd_ascii ? record_bytes_ : 3;
    if (tokens.size() < needed) {
      throw UsageError(fmt::format("\"{}\" line {} has {} values; {} expected", path_, line_,
                                   tokens.size(), needed));
    }
    float xyz[3];
    for (int a = 0; a < 3; ++a) {
      const std::string& token = tokens[pcd_ascii ? xyz_[a].offset : a];
      try {
        std::size_t used = 0;
        xyz[a] = std::stof(token, &used);
        if (used != token.size()) throw std::invalid_argument(token);
      } catch (const std::out_of_range&) {
        xyz[a] = std::numeric_limits<float>::infinity();  // Dropped by the server, as NaN.
      } catch (const std::exception&) {
        throw UsageError(
            fmt::format("\"{}\" line {}: \"{}\" is not a number", path_, line_, token));
      }
    }
    AppendPoint(xyz[0], xyz[1], xyz[2], chunk);
    ++n;
  }
  points_read_ += n;
  return n > 0;
}

}  // namespace strata::cli
