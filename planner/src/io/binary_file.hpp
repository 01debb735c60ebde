#pragma once
// The binary files Strata writes (saved models, saved graphs): how values become bytes and
// back, and the frame around them. Internal to the planner library's io/.
//
// A file: its magic (8 bytes), its format version (u32), the writer's version string (u32
// length + bytes, at most kMaxWriterBytes), the payload's length (u64), the payload, and an
// XXH3-64 checksum (u64) of every byte before it. Values are little-endian; named scalar
// fields (ForEachField) are stored with their names, so a reader tells which one it lacks.

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <xxhash.h>

#include "strata/named_file.hpp"
#include "strata/status.hpp"

namespace strata::binary_file {

// The format stores values as this machine holds them; it is defined as little-endian.
static_assert(std::endian::native == std::endian::little,
              "saved models are little-endian: a big-endian build needs byte swapping here");

template <typename T>
inline void Encode(char* bytes, T value) {
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
inline T Decode(const char* bytes) {
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

/// What kind of file a frame holds: what its first bytes are, which format version this build
/// reads, and what messages call it.
struct FileKind {
  std::string_view magic;  ///< 8 bytes.
  std::uint32_t format_version = 0;
  std::string_view noun;  ///< "saved model", "saved graph".
  /// What to do with a file of another format version, e.g. "assess the map again".
  std::string_view redo;
};

/// The frame's header: magic, format version and writer.
inline constexpr std::uint32_t kMaxWriterBytes = 256;

/// "strata <version>".
std::string WriterVersion();

/// Writes a whole file of `kind` to `sink`: header, the payload `write_payload` writes (run
/// twice: once into a counting sink for its length, then for real), checksum.
void WriteFrame(Sink& sink, const FileKind& kind, const std::function<void(Sink&)>& write_payload);

/// Reads the frame's header from `source` (a file of `total_bytes`), refusing with
/// kMapLoadFailed a file that is not of `kind`, of another version, or whose length
/// disagrees; sets *writer and leaves the source's budget at the payload. Messages call the
/// file "<noun> <name>".
Status ReadHeader(Source& source, std::uint64_t total_bytes, const FileKind& kind,
                  const std::string& name, std::string* writer);

/// Reads the payload with `read_payload` (false, with *problem set or not, when it is
/// inconsistent), then the checksum; a corrupted file is refused for its checksum before any
/// inconsistency is reported. kMapLoadFailed naming the file.
Status ReadFrame(Source& source, std::uint64_t total_bytes, const FileKind& kind,
                 const std::string& name,
                 const std::function<bool(Reader&, std::string* problem)>& read_payload);

/// ReadFrame over the file `file` (read in one pass).
Status ReadFrameFromFile(const NamedFile& file, const FileKind& kind,
                         const std::function<bool(Reader&, std::string* problem)>& read_payload);

/// Writes a file of `kind` at `path` atomically (a temporary beside it, renamed over it).
/// kMapLoadFailed naming the path when it cannot be written.
Status WriteFileAtomically(const std::string& path, const FileKind& kind,
                           const std::function<void(Sink&)>& write_payload);

}  // namespace strata::binary_file
