#include "binary_file.hpp"

#include <cerrno>
#include <filesystem>
#include <random>

#include <fmt/format.h>

#include "strata/version.hpp"

namespace strata::binary_file {
namespace {

// Magic, format version, writer length; then the writer, the payload length, the payload and
// the checksum.
constexpr std::size_t kFixedHeaderBytes = 8 + 4 + 4;

}  // namespace

std::string WriterVersion() { return std::string("strata ") + kStrataVersion; }

void WriteFrame(Sink& sink, const FileKind& kind, const std::function<void(Sink&)>& write_payload) {
  Sink counter;
  write_payload(counter);
  sink.Bytes(kind.magic.data(), kind.magic.size());
  sink.Value(kind.format_version);
  sink.String(WriterVersion());
  sink.Value(counter.count());
  write_payload(sink);
  sink.Checksum();
}

Status ReadHeader(Source& source, std::uint64_t total_bytes, const FileKind& kind,
                  const std::string& name, std::string* writer) {
  const auto fail = [&](const std::string& what) {
    return Error{ErrorCode::kMapLoadFailed, fmt::format("{} {} {}", kind.noun, name, what)};
  };
  Reader reader(&source);
  char magic[8];
  std::uint32_t version = 0;
  source.set_remaining(kFixedHeaderBytes);
  if (!source.Read(magic, sizeof(magic)) || std::string_view(magic, sizeof(magic)) != kind.magic) {
    return fail(
        fmt::format("is not a Strata {} (it does not start with {})", kind.noun, kind.magic));
  }
  if (!reader.Value(&version)) return fail("is truncated in its header");
  if (version != kind.format_version) {
    return fail(fmt::format("has format version {}; this build ({}) reads version {}: {}", version,
                            WriterVersion(), kind.format_version, kind.redo));
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

Status ReadFrame(Source& source, std::uint64_t total_bytes, const FileKind& kind,
                 const std::string& name,
                 const std::function<bool(Reader&, std::string* problem)>& read_payload) {
  const auto fail = [&](const std::string& what) {
    return Error{ErrorCode::kMapLoadFailed, fmt::format("{} {} {}", kind.noun, name, what)};
  };
  std::string writer;
  if (Status s = ReadHeader(source, total_bytes, kind, name, &writer); !s) return s;
  Reader reader(&source);
  std::string problem;
  const bool parsed = read_payload(reader, &problem) && source.remaining() == 0;
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
  return Status::Ok();
}

Status ReadFrameFromFile(const NamedFile& file, const FileKind& kind,
                         const std::function<bool(Reader&, std::string* problem)>& read_payload) {
  std::error_code error;
  const std::uintmax_t size = std::filesystem::file_size(file.path, error);
  if (error) {
    return Error{ErrorCode::kMapLoadFailed,
                 fmt::format("{} {}: {}", kind.noun, file.name, error.message())};
  }
  std::ifstream stream(file.path, std::ios::binary);
  if (!stream) {
    return Error{ErrorCode::kMapLoadFailed, fmt::format("{} {} cannot be opened: {}", kind.noun,
                                                        file.name, std::strerror(errno))};
  }
  FileSource source(&stream);
  return ReadFrame(source, size, kind, file.name, read_payload);
}

Status WriteFileAtomically(const std::string& path, const FileKind& kind,
                           const std::function<void(Sink&)>& write_payload) {
  namespace fs = std::filesystem;
  const auto fail = [&](const std::string& what) {
    return Error{ErrorCode::kMapLoadFailed,
                 fmt::format("cannot write the {} {}: {}", kind.noun, path, what)};
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
    WriteFrame(sink, kind, write_payload);
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

}  // namespace strata::binary_file
