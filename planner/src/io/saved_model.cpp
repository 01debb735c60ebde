#include "strata/io/saved_model.hpp"

#include <bit>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <type_traits>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <xxhash.h>

#include "strata/version.hpp"

namespace strata {
namespace {

// The format stores values as this machine holds them; it is defined as little-endian.
static_assert(std::endian::native == std::endian::little,
              "saved models are little-endian: a big-endian build needs byte swapping here");

constexpr std::uint32_t kMaxWriterBytes = 256;
// Magic, format version, writer length; then the writer, the payload length, the payload and
// the checksum.
constexpr std::size_t kFixedHeaderBytes = 8 + 4 + 4;

// Bytes per stored ColumnSurface and Interval (field by field, no padding).
constexpr std::size_t kSurfaceRecordBytes = 4 * 4 + 2 * 4 + 1;
constexpr std::size_t kIntervalRecordBytes = 4 + 4;

template <typename T>
void Encode(char* bytes, T value) {
  std::memcpy(bytes, &value, sizeof(T));
}

// Where serialised bytes go: a string, a file, or nowhere (to count them). Every byte written
// passes through the checksum; a counting sink neither hashes nor encodes.
class Sink {
 public:
  explicit Sink(std::string* out = nullptr, std::ofstream* file = nullptr)
      : out_(out), file_(file), hash_(XXH3_createState()) {
    XXH3_64bits_reset(hash_);
  }
  ~Sink() { XXH3_freeState(hash_); }
  Sink(const Sink&) = delete;
  Sink& operator=(const Sink&) = delete;

  void Bytes(const void* data, std::size_t n) {
    count_ += n;
    if (n == 0 || counting()) return;
    XXH3_64bits_update(hash_, data, n);
    if (out_ != nullptr) out_->append(static_cast<const char*>(data), n);
    if (file_ != nullptr)
      file_->write(static_cast<const char*>(data), static_cast<std::streamsize>(n));
  }
  template <typename T>
  void Value(T value) {
    static_assert(std::is_arithmetic_v<T>);
    Bytes(&value, sizeof(T));
  }
  void String(std::string_view s) {
    Value(static_cast<std::uint32_t>(s.size()));
    Bytes(s.data(), s.size());
  }
  template <typename T>
  void Array(const std::vector<T>& v) {
    static_assert(std::is_arithmetic_v<T>);
    Value(static_cast<std::uint64_t>(v.size()));
    Bytes(v.data(), v.size() * sizeof(T));
  }
  // Each element of `items` as kRecordBytes bytes (encode(item, bytes)), in chunks.
  template <std::size_t kRecordBytes, typename T, typename Encode>
  void Records(const std::vector<T>& items, const Encode& encode) {
    if (counting()) {
      count_ += items.size() * kRecordBytes;
      return;
    }
    constexpr std::size_t kChunkRecords = 1 << 14;
    char buffer[kChunkRecords * kRecordBytes];
    for (std::size_t first = 0; first < items.size(); first += kChunkRecords) {
      const std::size_t count = std::min(kChunkRecords, items.size() - first);
      for (std::size_t i = 0; i < count; ++i) encode(items[first + i], buffer + i * kRecordBytes);
      Bytes(buffer, count * kRecordBytes);
    }
  }
  // The checksum of everything written so far, written last (not itself hashed).
  void Checksum() {
    const std::uint64_t digest = XXH3_64bits_digest(hash_);
    if (out_ != nullptr) out_->append(reinterpret_cast<const char*>(&digest), sizeof(digest));
    if (file_ != nullptr) file_->write(reinterpret_cast<const char*>(&digest), sizeof(digest));
  }
  std::uint64_t count() const { return count_; }

 private:
  bool counting() const { return out_ == nullptr && file_ == nullptr; }

  std::string* out_;
  std::ofstream* file_;
  XXH3_state_t* hash_;
  std::uint64_t count_ = 0;
};

// Named scalar fields (ForEachField): name, type tag, value as 8 bytes.
enum class FieldType : std::uint8_t { kDouble = 1, kInteger = 2, kBool = 3 };

template <typename T>
constexpr FieldType TypeOf() {
  if constexpr (std::is_same_v<T, bool>) {
    return FieldType::kBool;
  } else if constexpr (std::is_integral_v<T>) {
    return FieldType::kInteger;
  } else {
    static_assert(std::is_floating_point_v<T>);
    return FieldType::kDouble;
  }
}

template <typename Fields>
void WriteFields(Sink& sink, const Fields& fields) {
  std::uint32_t count = 0;
  ForEachField(fields, [&](const char*, const auto&) { ++count; });
  sink.Value(count);
  ForEachField(fields, [&](const char* name, const auto& value) {
    using T = std::remove_cvref_t<decltype(value)>;
    sink.String(name);
    sink.Value(static_cast<std::uint8_t>(TypeOf<T>()));
    if constexpr (TypeOf<T>() == FieldType::kDouble) {
      sink.Value(static_cast<double>(value));
    } else {
      sink.Value(static_cast<std::int64_t>(value));
    }
  });
}

void WriteGeometry(Sink& sink, const GridGeometry& g) {
  for (int a = 0; a < 3; ++a) sink.Value(g.origin_m[a]);
  sink.Value(g.resolution_m);
  for (int a = 0; a < 3; ++a) sink.Value(static_cast<std::int32_t>(g.size[a]));
}

void WritePayload(Sink& sink, const TerrainModel& model) {
  WriteFields(sink, model.config());
  WriteFields(sink, model.summary());
  const SurfaceMap& surfaces = model.surfaces();
  WriteGeometry(sink, surfaces.geometry());
  sink.Array(surfaces.column_begin());
  // Records field by field (the structs' padding would make the bytes depend on the
  // compiler), gathered into chunks so that the checksum sees large writes.
  sink.Value(static_cast<std::uint64_t>(surfaces.all_surfaces().size()));
  sink.Records<kSurfaceRecordBytes>(surfaces.all_surfaces(), [](const ColumnSurface& s, char* b) {
    Encode(b, s.ground_z_m);
    Encode(b + 4, s.clearance_m);
    Encode(b + 8, s.tilt_rad);
    Encode(b + 12, s.plane_center_z_m);
    Encode(b + 16, s.top_layer);
    Encode(b + 20, s.bottom_layer);
    Encode(b + 24, static_cast<std::uint8_t>(s.valid));
  });
  const TerrainFields::Parts& f = model.fields().parts();
  WriteGeometry(sink, f.geometry);
  sink.Value(f.distance_cap_m);
  sink.Value(f.safety_step);
  sink.Value(f.safety_background);
  sink.Array(f.column_begin);
  sink.Value(static_cast<std::uint64_t>(f.intervals.size()));
  sink.Records<kIntervalRecordBytes>(f.intervals, [](const TerrainFields::Interval& i, char* b) {
    Encode(b, i.first_layer);
    Encode(b + 4, i.offset);
  });
  sink.Array(f.distance);
  sink.Array(f.safety);
}

std::string WriterVersion() { return std::string("strata ") + kStrataVersion; }

// Writes the whole file: header, payload, checksum. The payload's length comes first, so the
// payload goes through a counting sink first (sizes only, no encoding or hashing).
void WriteModel(Sink& sink, const TerrainModel& model) {
  Sink counter;
  WritePayload(counter, model);
  sink.Bytes(kSavedModelMagic.data(), kSavedModelMagic.size());
  sink.Value(kSavedModelFormatVersion);
  sink.String(WriterVersion());
  sink.Value(counter.count());
  WritePayload(sink, model);
  sink.Checksum();
}

// Where serialised bytes come from, hashing every byte read.
class Source {
 public:
  Source() : hash_(XXH3_createState()) { XXH3_64bits_reset(hash_); }
  virtual ~Source() { XXH3_freeState(hash_); }
  Source(const Source&) = delete;
  Source& operator=(const Source&) = delete;

  // Reads n bytes into dst (hashing them); false when fewer are left.
  bool Read(void* dst, std::size_t n) {
    if (n == 0) return true;  // dst may be an empty vector's null data().
    if (n > remaining_) return false;
    if (!ReadRaw(dst, n)) return false;
    XXH3_64bits_update(hash_, dst, n);
    remaining_ -= n;
    return true;
  }
  // Reads and hashes whatever is left of the current budget.
  bool Skip() {
    char buffer[1 << 16];
    while (remaining_ > 0) {
      if (!Read(buffer, std::min<std::uint64_t>(remaining_, sizeof(buffer)))) return false;
    }
    return true;
  }
  // Bytes the current read may still take.
  std::uint64_t remaining() const { return remaining_; }
  void set_remaining(std::uint64_t n) { remaining_ = n; }
  std::uint64_t digest() const { return XXH3_64bits_digest(hash_); }
  // The stored checksum, after the payload (not hashed).
  virtual bool ReadChecksum(std::uint64_t* checksum) = 0;

 protected:
  virtual bool ReadRaw(void* dst, std::size_t n) = 0;

 private:
  XXH3_state_t* hash_;
  std::uint64_t remaining_ = 0;
};

class MemorySource final : public Source {
 public:
  explicit MemorySource(std::string_view bytes) : bytes_(bytes) {}
  bool ReadChecksum(std::uint64_t* checksum) override {
    if (bytes_.size() - position_ != sizeof(*checksum)) return false;
    std::memcpy(checksum, bytes_.data() + position_, sizeof(*checksum));
    return true;
  }

 private:
  bool ReadRaw(void* dst, std::size_t n) override {
    if (bytes_.size() - position_ < n) return false;
    std::memcpy(dst, bytes_.data() + position_, n);
    position_ += n;
    return true;
  }
  std::string_view bytes_;
  std::size_t position_ = 0;
};

class FileSource final : public Source {
 public:
  explicit FileSource(std::ifstream* file) : file_(file) {}
  bool ReadChecksum(std::uint64_t* checksum) override {
    file_->read(reinterpret_cast<char*>(checksum), sizeof(*checksum));
    return static_cast<std::size_t>(file_->gcount()) == sizeof(*checksum) &&
           file_->peek() == std::ifstream::traits_type::eof();
  }

 private:
  bool ReadRaw(void* dst, std::size_t n) override {
    file_->read(static_cast<char*>(dst), static_cast<std::streamsize>(n));
    return static_cast<std::size_t>(file_->gcount()) == n;
  }
  std::ifstream* file_;
};

// Reads the payload's values; every length is checked against the bytes left first, so a
// corrupted length cannot make it allocate more than the file holds.
class Reader {
 public:
  explicit Reader(Source* source) : source_(source) {}

  template <typename T>
  bool Value(T* value) {
    static_assert(std::is_arithmetic_v<T>);
    return source_->Read(value, sizeof(T));
  }
  bool String(std::string* s, std::uint32_t max_bytes) {
    std::uint32_t n = 0;
    if (!Value(&n) || n > max_bytes || n > source_->remaining()) return false;
    s->resize(n);
    return source_->Read(s->data(), n);
  }
  template <typename T>
  bool Array(std::vector<T>* v) {
    std::uint64_t n = 0;
    if (!Value(&n) || n > source_->remaining() / sizeof(T)) return false;
    v->resize(n);
    return source_->Read(v->data(), n * sizeof(T));
  }
  // A count of records of `record_bytes` each, checked against the bytes left.
  bool Count(std::uint64_t* n, std::size_t record_bytes) {
    return Value(n) && *n <= source_->remaining() / record_bytes;
  }
  // Reads `n` records of kRecordBytes each, in chunks, calling decode(bytes, index) for each:
  // one read per chunk rather than one per field keeps loading at the speed of memory.
  template <std::size_t kRecordBytes, typename Decode>
  bool Records(std::uint64_t n, const Decode& decode) {
    constexpr std::uint64_t kChunkRecords = 1 << 14;
    buffer_.resize(std::min(n, kChunkRecords) * kRecordBytes);
    for (std::uint64_t first = 0; first < n; first += kChunkRecords) {
      const std::uint64_t count = std::min(kChunkRecords, n - first);
      if (!source_->Read(buffer_.data(), count * kRecordBytes)) return false;
      for (std::uint64_t i = 0; i < count; ++i) {
        if (!decode(buffer_.data() + i * kRecordBytes, first + i)) return false;
      }
    }
    return true;
  }

 private:
  Source* source_;
  std::vector<char> buffer_;
};

template <typename T>
T Decode(const char* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

template <typename Fields>
bool ReadFields(Reader& reader, Fields* fields, std::string* problem) {
  std::uint32_t count = 0;
  if (!reader.Value(&count) || count > 1000) return false;
  std::map<std::string, std::pair<FieldType, std::int64_t>> integers;
  std::map<std::string, double> doubles;
  for (std::uint32_t i = 0; i < count; ++i) {
    std::string name;
    std::uint8_t type = 0;
    if (!reader.String(&name, 128) || !reader.Value(&type)) return false;
    if (type == static_cast<std::uint8_t>(FieldType::kDouble)) {
      double value = 0;
      if (!reader.Value(&value)) return false;
      doubles[name] = value;
    } else if (type == static_cast<std::uint8_t>(FieldType::kInteger) ||
               type == static_cast<std::uint8_t>(FieldType::kBool)) {
      std::int64_t value = 0;
      if (!reader.Value(&value)) return false;
      integers[name] = {static_cast<FieldType>(type), value};
    } else {
      *problem = "field '" + name + "' has an unknown type";
      return false;
    }
  }
  // A name this build does not know is the first thing to say: the file is from another
  // build, and everything else follows from that.
  std::map<std::string, bool> known;
  ForEachField(*fields, [&](const char* name, const auto&) { known[name] = true; });
  for (const auto& [name, value] : doubles) {
    if (!known.contains(name)) {
      *problem = "field '" + name + "' is unknown to this build";
      return false;
    }
  }
  for (const auto& [name, value] : integers) {
    if (!known.contains(name)) {
      *problem = "field '" + name + "' is unknown to this build";
      return false;
    }
  }
  bool complete = true;
  ForEachField(*fields, [&](const char* name, auto& value) {
    using T = std::remove_cvref_t<decltype(value)>;
    if constexpr (TypeOf<T>() == FieldType::kDouble) {
      const auto it = doubles.find(name);
      if (it == doubles.end()) {
        complete = false;
        *problem = std::string("field '") + name + "' is missing";
        return;
      }
      value = static_cast<T>(it->second);
      doubles.erase(it);
    } else {
      const auto it = integers.find(name);
      if (it == integers.end() || it->second.first != TypeOf<T>()) {
        complete = false;
        *problem = std::string("field '") + name + "' is missing";
        return;
      }
      value = static_cast<T>(it->second.second);
      integers.erase(it);
    }
  });
  if (complete && (!doubles.empty() || !integers.empty())) {
    *problem = "field '" + (doubles.empty() ? integers.begin()->first : doubles.begin()->first) +
               "' has the wrong type";
    return false;
  }
  return complete;
}

bool ReadGeometry(Reader& reader, GridGeometry* g) {
  for (int a = 0; a < 3; ++a) {
    if (!reader.Value(&g->origin_m[a])) return false;
  }
  if (!reader.Value(&g->resolution_m)) return false;
  for (int a = 0; a < 3; ++a) {
    std::int32_t n = 0;
    if (!reader.Value(&n)) return false;
    g->size[a] = n;
  }
  return g->origin_m.allFinite() && std::isfinite(g->resolution_m) && g->resolution_m > 0 &&
         (g->size.array() >= 1).all();
}

struct Payload {
  AssessmentConfig config;
  AssessmentSummary summary;
  GridGeometry surface_geometry;
  std::vector<std::uint32_t> column_begin;
  std::vector<ColumnSurface> surfaces;
  TerrainFields::Parts fields;
};

bool ReadPayload(Reader& reader, Payload* p, std::string* problem) {
  if (!ReadFields(reader, &p->config, problem) || !ReadFields(reader, &p->summary, problem)) {
    return false;
  }
  if (!ReadGeometry(reader, &p->surface_geometry) || !reader.Array(&p->column_begin)) return false;
  std::uint64_t n = 0;
  if (!reader.Count(&n, kSurfaceRecordBytes)) return false;
  p->surfaces.resize(n);
  if (!reader.Records<kSurfaceRecordBytes>(n, [&](const char* b, std::uint64_t i) {
        ColumnSurface& s = p->surfaces[i];
        s.ground_z_m = Decode<float>(b);
        s.clearance_m = Decode<float>(b + 4);
        s.tilt_rad = Decode<float>(b + 8);
        s.plane_center_z_m = Decode<float>(b + 12);
        s.top_layer = Decode<std::int32_t>(b + 16);
        s.bottom_layer = Decode<std::int32_t>(b + 20);
        const auto valid = Decode<std::uint8_t>(b + 24);
        s.valid = valid != 0;
        return valid <= 1;
      })) {
    return false;
  }
  TerrainFields::Parts& f = p->fields;
  if (!ReadGeometry(reader, &f.geometry) || !reader.Value(&f.distance_cap_m) ||
      !reader.Value(&f.safety_step) || !reader.Value(&f.safety_background) ||
      !reader.Array(&f.column_begin) || !reader.Count(&n, kIntervalRecordBytes)) {
    return false;
  }
  f.intervals.resize(n);
  if (!reader.Records<kIntervalRecordBytes>(n, [&](const char* b, std::uint64_t i) {
        f.intervals[i] = {Decode<std::int32_t>(b), Decode<std::uint32_t>(b + 4)};
        return true;
      })) {
    return false;
  }
  return reader.Array(&f.distance) && reader.Array(&f.safety);
}

// The header up to the payload: checks the magic, the version and the length. Sets
// *writer, and leaves the source's budget at the payload.
Status ReadHeader(Source& source, std::uint64_t total_bytes, const std::string& name,
                  std::string* writer) {
  const auto fail = [&name](const std::string& what) {
    return Error{ErrorCode::kMapLoadFailed, "saved model " + name + " " + what};
  };
  Reader reader(&source);
  char magic[8];
  std::uint32_t version = 0;
  source.set_remaining(kFixedHeaderBytes);
  if (!source.Read(magic, sizeof(magic)) ||
      std::string_view(magic, sizeof(magic)) != kSavedModelMagic) {
    return fail("is not a Strata saved model (it does not start with " +
                std::string(kSavedModelMagic) + ")");
  }
  if (!reader.Value(&version)) return fail("is truncated in its header");
  if (version != kSavedModelFormatVersion) {
    return fail(
        fmt::format("has format version {}; this build ({}) reads version {}: assess the "
                    "map again and save it with this build",
                    version, WriterVersion(), kSavedModelFormatVersion));
  }
  std::uint32_t writer_bytes = 0;
  if (!reader.Value(&writer_bytes)) return fail("is truncated in its header");
  if (writer_bytes > kMaxWriterBytes) return fail("has a corrupted header");
  std::string writer_text(writer_bytes, '\0');
  std::uint64_t payload_bytes = 0;
  source.set_remaining(writer_bytes + sizeof(payload_bytes));
  if (!source.Read(writer_text.data(), writer_bytes) || !reader.Value(&payload_bytes)) {
    return fail("is truncated in its header");
  }
  const std::uint64_t header_bytes = kFixedHeaderBytes + writer_bytes + sizeof(payload_bytes);
  if (total_bytes < header_bytes + sizeof(std::uint64_t) ||
      payload_bytes != total_bytes - header_bytes - sizeof(std::uint64_t)) {
    return fail(
        fmt::format("is truncated or has trailing bytes: {} bytes where its header "
                    "promises {}",
                    total_bytes, header_bytes + payload_bytes + sizeof(std::uint64_t)));
  }
  source.set_remaining(payload_bytes);
  *writer = std::move(writer_text);
  return Status::Ok();
}

Expected<std::shared_ptr<const TerrainModel>> Read(Source& source, std::uint64_t total_bytes,
                                                   const std::string& name) {
  const auto fail = [&name](const std::string& what) {
    return Error{ErrorCode::kMapLoadFailed, "saved model " + name + " " + what};
  };
  std::string writer;
  if (Status s = ReadHeader(source, total_bytes, name, &writer); !s) return s.error();
  Reader reader(&source);
  Payload payload;
  std::string problem;
  const bool parsed = ReadPayload(reader, &payload, &problem) && source.remaining() == 0;
  if (!parsed) source.Skip();  // Hash the rest: corruption or a consistent but wrong file?
  std::uint64_t stored = 0;
  if (!source.ReadChecksum(&stored)) return fail("is truncated: its checksum is missing");
  if (stored != source.digest()) {
    return fail("is corrupted: its checksum does not match its contents");
  }
  if (!parsed) {
    return fail(
        "written by " + writer + " is inconsistent" +
        (problem.empty() ? std::string(" (a length or a value is out of range)") : ": " + problem));
  }
  if (Status s = payload.config.Validate(); !s) {
    return fail("holds invalid assessment parameters: " + s.error().message);
  }
  Expected<SurfaceMap> surfaces = SurfaceMap::FromParts(
      payload.surface_geometry, std::move(payload.column_begin), std::move(payload.surfaces));
  if (!surfaces) return fail("is inconsistent: " + surfaces.error().message);
  Expected<TerrainFields> fields = TerrainFields::FromParts(std::move(payload.fields));
  if (!fields) return fail("is inconsistent: " + fields.error().message);
  Expected<std::shared_ptr<const TerrainModel>> model = TerrainModel::FromParts(
      payload.config, payload.summary, std::move(surfaces).value(), std::move(fields).value());
  if (!model) return fail("is inconsistent: " + model.error().message);
  return model;
}

}  // namespace

bool IsSavedModel(std::string_view first_bytes) {
  return first_bytes.substr(0, kSavedModelMagic.size()) == kSavedModelMagic;
}

bool IsSavedModelFile(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  char magic[kSavedModelMagic.size()];
  file.read(magic, sizeof(magic));
  return file.gcount() == sizeof(magic) && IsSavedModel(std::string_view(magic, sizeof(magic)));
}

Expected<AssessmentConfig> ReadSavedModelConfig(const NamedFile& named) {
  const std::string& path = named.path;
  const std::string& name = named.name;
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  std::ifstream file(path, std::ios::binary);
  if (error || !file) {
    return Error{ErrorCode::kMapLoadFailed, "saved model " + name + " cannot be read"};
  }
  FileSource source(&file);
  std::string writer;
  if (Status s = ReadHeader(source, size, name, &writer); !s) return s.error();
  Reader reader(&source);
  AssessmentConfig config;
  std::string problem;
  if (!ReadFields(reader, &config, &problem)) {
    return Error{ErrorCode::kMapLoadFailed, "saved model " + name + " written by " + writer +
                                                " has unreadable parameters" +
                                                (problem.empty() ? "" : ": " + problem)};
  }
  return config;
}

std::string SerializeModel(const TerrainModel& model) {
  std::string out;
  Sink sink(&out);
  WriteModel(sink, model);
  return out;
}

Status SaveModel(const TerrainModel& model, const std::string& path) {
  namespace fs = std::filesystem;
  const auto fail = [&path](const std::string& what) {
    return Error{ErrorCode::kMapLoadFailed, "cannot save the model to " + path + ": " + what};
  };
  // A unique temporary name in the same directory, so the rename is atomic.
  std::random_device random;
  const std::string temporary = path + ".tmp-" + std::to_string(random());
  {
    errno = 0;
    std::ofstream file(temporary, std::ios::binary | std::ios::trunc);
    if (!file) {
      return fail(errno != 0 ? std::strerror(errno) : "cannot create " + temporary);
    }
    Sink sink(nullptr, &file);
    WriteModel(sink, model);
    file.flush();
    if (!file) {
      std::error_code ignored;
      fs::remove(temporary, ignored);
      return fail("writing failed (is the disk full?)");
    }
  }
  std::error_code error;
  fs::rename(temporary, path, error);
  if (error) {
    // The rename's reason, not the clean-up's (which succeeds: "Success" was reported).
    std::error_code ignored;
    fs::remove(temporary, ignored);
    return fail(error.message());
  }
  return Status::Ok();
}

Expected<std::shared_ptr<const TerrainModel>> DeserializeModel(std::string_view bytes,
                                                               const std::string& name) {
  MemorySource source(bytes);
  return Read(source, bytes.size(), name);
}

Expected<std::shared_ptr<const TerrainModel>> LoadModel(const NamedFile& named) {
  const std::string& path = named.path;
  const std::string& name = named.name;
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  if (error) {
    return Error{ErrorCode::kMapLoadFailed, "saved model " + name + ": " + error.message()};
  }
  std::ifstream file(path, std::ios::binary);
  if (!file) {
    return Error{ErrorCode::kMapLoadFailed,
                 "saved model " + name + " cannot be opened: " + std::strerror(errno)};
  }
  FileSource source(&file);
  return Read(source, size, name);
}

}  // namespace strata
