#include "maps/map_store.hpp"

#include "common/map_id.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <sstream>
#include <system_error>
#include <type_traits>
#include <unordered_set>
#include <utility>

#include <fmt/format.h>
#include <xxhash.h>

#include "maps/store_files.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/io/model_tiles.hpp"
#include "strata/io/saved_graph.hpp"
#include "strata/io/saved_model.hpp"

namespace strata::server {
namespace {

namespace fs = std::filesystem;
using store_files::ErrnoText;
using store_files::Fd;
using store_files::ReadFileIfExists;
using store_files::RemoveAllInSlices;
using store_files::RenameDurably;
using store_files::Sync;
using store_files::Unavailable;
using store_files::UniqueName;
using store_files::WriteNewFile;

static_assert(std::endian::native == std::endian::little,
              "version names hash little-endian bytes: a big-endian build needs byte swapping");
static_assert(sizeof(Eigen::Vector3f) == 3 * sizeof(float), "points are three packed floats");

constexpr std::string_view kMarkerName = "strata-map-store";
constexpr std::string_view kMarkerText = "strata map store, layout 3\n";
// Layout 1 held each version's cloud and model in its own directory, layout 2 in its
// terrain's; layout 3 (tiles) reads both.
constexpr std::string_view kOlderMarkerTexts[] = {"strata map store, layout 1\n",
                                                  "strata map store, layout 2\n"};
constexpr const char* kHeadName = "head";
constexpr const char* kLockName = "lock";
// At the root: locked shared by every write in flight, tried exclusively by the removers.
constexpr std::string_view kWritingName = "writing";
// How often a remover looks again while another process writes [a write takes 1-60 ms].
constexpr std::chrono::milliseconds kOthersWritingPoll{2};
constexpr const char* kVersionsName = "versions";
constexpr const char* kTerrainsName = "terrains";
constexpr const char* kGraphsName = "graphs";
constexpr const char* kGraphExtension = ".stratagraph";
constexpr const char* kTerrainName = "terrain";  // In a version: the name of its terrain.
// Under a map: its tiles; in a terrain: the list of the tiles it is made of.
constexpr const char* kTilesName = "tiles";
// Up to this many new tiles are made durable one fsync each, more by one syncfs(2).
constexpr std::ptrdiff_t kMaxTilesSyncedEach = 64;
constexpr const char* kCloudName = "cloud.pcd";
constexpr const char* kModelName = "model.stratamodel";
constexpr const char* kMetadataName = "metadata";
constexpr std::size_t kVersionDigits = 32;  // XXH3-128 in hex.
// A deletion racing a writer (the map directory renamed away between mkdir and rename) is
// retried this often before the writer gives up.
constexpr int kMaxAttempts = 8;

// Callers validate ids already; this keeps any other id from naming something outside
// maps/<id> ("..", a slash, a NUL).
ServiceStatus CheckId(const std::string& id) { return ValidateMapId(id); }

ServiceStatus CheckVersion(const std::string& version) {
  if (MapStore::IsVersion(version)) return OkStatus();
  return MakeError(ErrorCode::kInvalidInput,
                   "map version '" + version.substr(0, 64) +
                       "' is not valid: a version is 32 lowercase hex digits, as the map's "
                       "versions list shows")
      .Blame("version");
}

ServiceStatus CheckTerrain(const std::string& terrain) {
  if (MapStore::IsVersion(terrain)) return OkStatus();
  return MakeError(ErrorCode::kInvalidInput, "map store: terrain name '" + terrain.substr(0, 64) +
                                                 "' is not 32 lowercase hex digits");
}

// The kept versions a head lists, or nothing when the map has no head.
Result<std::optional<std::vector<std::string>>> ReadHead(const fs::path& map_dir) {
  const fs::path path = map_dir / kHeadName;
  Result<std::optional<std::string>> bytes = ReadFileIfExists(path);
  if (!bytes) return std::move(bytes).error();
  if (!bytes->has_value()) return std::optional<std::vector<std::string>>();
  std::vector<std::string> versions;
  std::istringstream lines(**bytes);
  for (std::string line; std::getline(lines, line);) versions.push_back(line);
  const bool well_formed =
      !versions.empty() && std::all_of(versions.begin(), versions.end(), MapStore::IsVersion);
  if (!well_formed) {
    return MakeError(ServiceErrorCode::kMapCorrupted,
                     "map store: '" + path.string() +
                         "' is not a list of versions (edited by hand?): restore it, or delete "
                         "the map and create it again");
  }
  return std::optional<std::vector<std::string>>(std::move(versions));
}

std::string JoinVersions(const std::vector<std::string>& versions) {
  std::string text;
  for (const std::string& version : versions) text += (text.empty() ? "" : ", ") + version;
  return text.empty() ? "none" : text;
}

// The modification time of `path` and of its direct children, whichever is newest: a
// directory's own time changes only when entries are added or removed, its files' when
// they are written.
fs::file_time_type NewestWrite(const fs::path& path) {
  std::error_code ec;
  fs::file_time_type newest = fs::last_write_time(path, ec);
  if (ec) return fs::file_time_type::max();  // Unknown: treat as new, keep it.
  if (fs::is_directory(path, ec)) {
    for (const fs::directory_entry& child : fs::directory_iterator(path, ec)) {
      const fs::file_time_type time = fs::last_write_time(child.path(), ec);
      if (ec) return fs::file_time_type::max();
      newest = std::max(newest, time);
    }
  }
  return newest;
}

bool IsStale(const fs::path& path) {
  return NewestWrite(path) < fs::file_time_type::clock::now() - kStaleTemporaryAge;
}

// flock(2) of `fd` (`operation`), through signals: 0, or -1 with errno set.
int Flock(const Fd& fd, int operation) {
  int locked = 0;
  do {
    locked = ::flock(fd.get(), operation);
  } while (locked != 0 && errno == EINTR);
  return locked;
}

// Serialises changes to one map (its head, its deletion) among every thread and process:
// a mutex per map directory for this process's threads (flock between two descriptors of
// one process is not exclusive on every file system: Linux's NFS client turns it into a
// per-process POSIX lock), then flock on maps/<id>/lock for other processes and hosts.
class MapLock {
 public:
  // Locks the map at `map_dir`. With `create`, makes its directory when absent; without,
  // fails with kMapNotFound then. The lock file checked after locking to be the one at the
  // path: a deletion may have renamed the directory away while this waited.
  static Result<MapLock> Acquire(const fs::path& map_dir, const std::string& id, bool create) {
    std::unique_lock<std::mutex> process_lock(ProcessMutex(map_dir));
    const fs::path lock_path = map_dir / kLockName;
    for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
      if (create && ::mkdir(map_dir.c_str(), 0755) != 0 && errno != EEXIST) {
        return Unavailable(map_dir, "create the map directory", errno);
      }
      Fd fd(::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644));
      if (!fd.valid()) {
        if (errno == ENOENT && !create) return NotFound(id);
        if (errno == ENOENT) continue;  // Deleted between mkdir and open.
        return Unavailable(lock_path, "open the lock file", errno);
      }
      if (Flock(fd, LOCK_EX) != 0) return Unavailable(lock_path, "lock", errno);
      struct stat held {};
      struct stat current {};
      if (::fstat(fd.get(), &held) != 0) return Unavailable(lock_path, "stat", errno);
      if (::stat(lock_path.c_str(), &current) == 0 && current.st_ino == held.st_ino &&
          current.st_dev == held.st_dev) {
        return MapLock(std::move(process_lock), std::move(fd));
      }
      // Deleted (and perhaps created again) while this waited: lock the one there now.
    }
    return MakeError(ServiceErrorCode::kMapStoreUnavailable,
                     "map store: map '" + id +
                         "' was deleted and created again repeatedly while waiting for its "
                         "lock: try again");
  }

  static ServiceError NotFound(const std::string& id) {
    return MakeError(ServiceErrorCode::kMapNotFound, "no map '" + id + "' in the map store")
        .With("map_id", id);
  }

 private:
  MapLock(std::unique_lock<std::mutex> process_lock, Fd fd)
      : process_lock_(std::move(process_lock)), fd_(std::move(fd)) {}

  static std::mutex& ProcessMutex(const fs::path& map_dir) {
    static std::mutex registry_mutex;
    // One per map directory ever locked: a few bytes each, never freed, so a reference
    // handed out stays valid.
    static std::map<std::string, std::unique_ptr<std::mutex>> mutexes;
    const std::lock_guard lock(registry_mutex);
    std::unique_ptr<std::mutex>& mutex = mutexes[map_dir.string()];
    if (!mutex) mutex = std::make_unique<std::mutex>();
    return *mutex;
  }

  // Released in reverse order: the file lock (closing the descriptor), then the mutex.
  std::unique_lock<std::mutex> process_lock_;
  Fd fd_;
};

// Replaces the head of `map_dir` with `versions`: a temporary in `tmp_dir`, then a rename.
ServiceStatus WriteHead(const fs::path& tmp_dir, const fs::path& map_dir,
                        const std::vector<std::string>& versions) {
  std::string text;
  for (const std::string& version : versions) text += version + "\n";
  const fs::path temporary = tmp_dir / UniqueName("head");
  ServiceStatus status = WriteNewFile(temporary, text);
  if (status) status = RenameDurably(temporary, map_dir / kHeadName);
  if (!status) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
  }
  return status;
}

ServiceError AlreadyExists(const std::string& id, const std::string& current) {
  return MakeError(ServiceErrorCode::kMapAlreadyExists,
                   "map '" + id + "' exists already (current version " + current +
                       "): choose another id, or delete the map first")
      .With("map_id", id);
}

ServiceError NotPut(const std::string& id, const std::string& version) {
  return MakeError(ServiceErrorCode::kMapVersionNotFound,
                   "map store: version " + version + " of map '" + id +
                       "' was not written (or the map was deleted since): put it again")
      .With("map_id", id);
}

ServiceError Changed(const std::string& id, const std::string& current,
                     const std::string& expected) {
  return MakeError(ServiceErrorCode::kMapChanged,
                   "map '" + id + "' changed: its current version is " + current + ", not " +
                       expected + ": apply the change to the current version")
      .With("map_id", id)
      .With("current_version", current);
}

ServiceError BadKeep(int keep_versions) {
  return MakeError(ErrorCode::kInvalidInput,
                   fmt::format("map store: keep_versions is {}, must be >= 1 (the current "
                               "version is always kept)",
                               keep_versions));
}

// The head after `version` is published over `kept`: it first, then the others, the newest
// `keep_versions`; `dropped` gets the rest.
std::vector<std::string> NextHead(const std::vector<std::string>& kept, const std::string& version,
                                  int keep_versions, std::vector<std::string>* dropped) {
  std::vector<std::string> next = {version};
  std::copy_if(kept.begin(), kept.end(), std::back_inserter(next),
               [&](const std::string& v) { return v != version; });
  if (next.size() > static_cast<std::size_t>(keep_versions)) {
    dropped->assign(next.begin() + keep_versions, next.end());
    next.resize(static_cast<std::size_t>(keep_versions));
  }
  return next;
}

template <typename T>
void HashValue(XXH3_state_t* state, T value) {
  XXH3_128bits_update(state, &value, sizeof(value));
}

void HashString(XXH3_state_t* state, std::string_view text) {
  HashValue(state, static_cast<std::uint64_t>(text.size()));
  XXH3_128bits_update(state, text.data(), text.size());
}

}  // namespace

namespace {

// Every assessment parameter by name except num_threads (how to assess, not what).
void HashConfig(XXH3_state_t* state, const AssessmentConfig& config) {
  ForEachField(config, [&](const char* name, const auto& value) {
    using Value = std::remove_cvref_t<decltype(value)>;
    if (std::string_view(name) == "num_threads") return;
    HashString(state, name);
    if constexpr (std::is_floating_point_v<Value>) {
      HashValue(state, static_cast<double>(value) + 0.0);  // -0.0 assesses as 0.0.
    } else {
      HashValue(state, static_cast<std::int64_t>(value));
    }
  });
}

}  // namespace

std::string MapStore::TerrainOf(const PointCloud& cloud, const AssessmentConfig& config) {
  XXH3_state_t* state = XXH3_createState();
  XXH3_128bits_reset(state);
  HashString(state, "strata map version");
  HashValue(state, kSavedModelFormatVersion);
  HashValue(state, static_cast<std::uint64_t>(cloud.size()));
  XXH3_128bits_update(state, cloud.data(), cloud.size() * sizeof(Eigen::Vector3f));
  HashConfig(state, config);
  // Layout 1 hashed the (then always empty) zone count here: a first version keeps its name.
  HashValue(state, std::uint64_t{0});
  const XXH128_hash_t digest = XXH3_128bits_digest(state);
  XXH3_freeState(state);
  return HexName(digest);
}

std::string MapStore::TerrainOfTiles(std::span<const std::string> cloud_tiles,
                                     const AssessmentConfig& config) {
  XXH3_state_t* state = XXH3_createState();
  XXH3_128bits_reset(state);
  HashString(state, "strata tiled terrain");
  HashValue(state, kSavedModelFormatVersion);
  HashValue(state, static_cast<std::uint64_t>(cloud_tiles.size()));
  for (const std::string& tile : cloud_tiles) HashString(state, tile);
  HashConfig(state, config);
  const XXH128_hash_t digest = XXH3_128bits_digest(state);
  XXH3_freeState(state);
  return HexName(digest);
}

std::string MapStore::VersionOf(std::string_view terrain, std::span<const Prism> keep_out) {
  if (keep_out.empty()) return std::string(terrain);
  XXH3_state_t* state = XXH3_createState();
  XXH3_128bits_reset(state);
  HashString(state, "strata map version with keep-out zones");
  HashString(state, terrain);
  HashValue(state, static_cast<std::uint64_t>(keep_out.size()));
  for (const Prism& zone : keep_out) {
    HashValue(state, static_cast<std::uint64_t>(zone.polygon_m.size()));
    for (const Eigen::Vector2d& corner : zone.polygon_m) {
      HashValue(state, corner.x() + 0.0);
      HashValue(state, corner.y() + 0.0);
    }
    HashValue(state, zone.z_min_m + 0.0);
    HashValue(state, zone.z_max_m + 0.0);
  }
  const XXH128_hash_t digest = XXH3_128bits_digest(state);
  XXH3_freeState(state);
  return HexName(digest);
}

std::string MapStore::VersionOf(const PointCloud& cloud, const AssessmentConfig& config,
                                std::span<const Prism> keep_out) {
  return VersionOf(TerrainOf(cloud, config), keep_out);
}

std::string MapStore::TerrainOfSavedModel(const std::string& path) {
  // The file's bytes determine the model (its format version and parameters are inside), so
  // they name it, apart from any cloud's versions by the prefix.
  XXH3_state_t* state = XXH3_createState();
  XXH3_128bits_reset(state);
  HashString(state, "strata saved model");
  std::vector<char> buffer(std::size_t{1} << 20);
  if (std::FILE* file = std::fopen(path.c_str(), "rb")) {
    std::size_t read = 0;
    while ((read = std::fread(buffer.data(), 1, buffer.size(), file)) > 0) {
      XXH3_128bits_update(state, buffer.data(), read);
    }
    std::fclose(file);
  }
  const XXH128_hash_t digest = XXH3_128bits_digest(state);
  XXH3_freeState(state);
  return HexName(digest);
}

bool MapStore::IsVersion(std::string_view version) {
  return version.size() == kVersionDigits &&
         std::all_of(version.begin(), version.end(),
                     [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}

Result<std::unique_ptr<MapStore>> MapStore::Open(fs::path root, std::shared_ptr<MapHeads> heads) {
  const auto invalid = [&](const std::string& why) {
    return MakeError(ErrorCode::kInvalidConfig,
                     "map store '" + root.string() + "' " + why +
                         ": give --map-store a writable directory (in Kubernetes, a "
                         "ReadWriteMany volume mounted with lock support)");
  };
  if (root.empty()) return invalid("is an empty path");
  std::error_code ec;
  fs::create_directories(root, ec);
  if (!fs::is_directory(root, ec)) {
    return invalid("is not a directory and cannot be created (" + ec.message() + ")");
  }
  root = fs::canonical(root, ec);
  if (ec) return invalid("cannot be resolved (" + ec.message() + ")");
  for (const char* sub : {"maps", "tmp", "trash"}) {
    fs::create_directory(root / sub, ec);
    if (ec)
      return invalid(std::string("has no ") + sub + "/ and it cannot be made (" + ec.message() +
                     ")");
  }

  // Writable, and locks work: a probe file, created, locked, removed.
  const fs::path probe = root / "tmp" / UniqueName("probe");
  if (ServiceStatus written = WriteNewFile(probe, "probe"); !written) {
    return invalid("is not writable (" + written.error().message + ")");
  }
  {
    const Fd fd(::open(probe.c_str(), O_RDWR | O_CLOEXEC));
    if (!fd.valid() || ::flock(fd.get(), LOCK_EX) != 0) {
      const int error = errno;
      fs::remove(probe, ec);
      return invalid("refuses file locks (" + ErrnoText(error) +
                     "; an NFS mount needs lock support, not 'nolock')");
    }
  }
  fs::remove(probe, ec);

  // The marker: written by the first server (temporary + rename), checked by every other.
  const fs::path marker = root / kMarkerName;
  Result<std::optional<std::string>> text = ReadFileIfExists(marker);
  if (text && !text->has_value()) {
    const fs::path temporary = root / "tmp" / UniqueName("marker");
    ServiceStatus written = WriteNewFile(temporary, kMarkerText);
    if (written) written = RenameDurably(temporary, marker);
    if (!written) return invalid("cannot be initialised (" + written.error().message + ")");
    text = ReadFileIfExists(marker);
  }
  if (text && text->has_value() &&
      std::find(std::begin(kOlderMarkerTexts), std::end(kOlderMarkerTexts), **text) !=
          std::end(kOlderMarkerTexts)) {
    // Layout 3 reads every version of layouts 1 and 2; from now on a server of those refuses
    // the store, rather than miss the cloud and model of versions it cannot read.
    const fs::path temporary = root / "tmp" / UniqueName("marker");
    ServiceStatus written = WriteNewFile(temporary, kMarkerText);
    if (written) written = RenameDurably(temporary, marker);
    if (!written) return invalid("cannot be taken over (" + written.error().message + ")");
    text = ReadFileIfExists(marker);
  }
  if (!text) return invalid("cannot be read (" + text.error().message + ")");
  if (!text->has_value() || **text != kMarkerText) {
    return invalid("holds a map store of another layout (its " + std::string(kMarkerName) +
                   " is not '" + std::string(kMarkerText.substr(0, kMarkerText.size() - 1)) + "')");
  }

  // The writes' lock file, and two descriptors of it (MapStore::WriteScope).
  const fs::path writing = root / kWritingName;
  Fd writing_shared(::open(writing.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644));
  Fd writing_probe(::open(writing.c_str(), O_RDWR | O_CLOEXEC));
  if (!writing_shared.valid() || !writing_probe.valid()) {
    return invalid("cannot open its " + std::string(kWritingName) + " file (" + ErrnoText(errno) +
                   ")");
  }
  std::unique_ptr<MapStore> store(new MapStore(
      std::move(root), std::move(heads), std::move(writing_shared), std::move(writing_probe)));
  store->CollectGarbage();
  return store;
}

fs::path MapStore::MapDir(const std::string& id) const { return root_ / "maps" / id; }

fs::path MapStore::VersionDir(const std::string& id, const std::string& version) const {
  return MapDir(id) / kVersionsName / version;
}

MapStore::MapStore(fs::path root, std::shared_ptr<MapHeads> heads, Fd writing_shared,
                   Fd writing_probe)
    : root_(std::move(root)),
      shared_heads_(std::move(heads)),
      writing_shared_(std::move(writing_shared)),
      writing_probe_(std::move(writing_probe)) {}

MapStore::~MapStore() {
  {
    const std::lock_guard lock(discarded_mutex_);
    closing_ = true;
  }
  discarded_changed_.notify_all();
  if (remover_.joinable()) remover_.join();
}

bool MapStore::Discard(const fs::path& path) const {
  const fs::path trash = root_ / "trash" / UniqueName("discarded");
  if (::rename(path.c_str(), trash.c_str()) != 0) return false;
  // Not made durable: after a crash that undid the rename, what comes back is a leftover no
  // head lists, which CollectGarbage removes; an fsync here would wait for the journal behind
  // every removal in flight.
  {
    const std::lock_guard lock(discarded_mutex_);
    discarded_.push_back(trash);
    // Started with the first discard, not with the store: a process that forks (a test's
    // writers) stays single-threaded until it removes something.
    if (!remover_.joinable()) remover_ = std::thread([this] { RemoveDiscarded(); });
  }
  discarded_changed_.notify_one();
  return true;
}

void MapStore::ScheduleTileCollection(const std::string& id) const {
  {
    const std::lock_guard lock(discarded_mutex_);
    tiles_to_collect_.insert(id);
    if (!remover_.joinable()) remover_ = std::thread([this] { RemoveDiscarded(); });
  }
  discarded_changed_.notify_one();
}

class MapStore::WriteScope {
 public:
  // The first scope of the store locks the `writing` file shared, for the other processes'
  // removers; blocking only for the instant another remover holds it in OthersWriting. A
  // file system that refuses (Open checked that locks work) leaves this process's gate alone.
  explicit WriteScope(const MapStore& store) : store_(store) {
    const std::lock_guard lock(store_.discarded_mutex_);
    if (++store_.writing_ == 1) (void)Flock(store_.writing_shared_, LOCK_SH);
  }
  ~WriteScope() {
    {
      const std::lock_guard lock(store_.discarded_mutex_);
      if (--store_.writing_ == 0) (void)Flock(store_.writing_shared_, LOCK_UN);
    }
    store_.discarded_changed_.notify_all();
  }
  WriteScope(const WriteScope&) = delete;
  WriteScope& operator=(const WriteScope&) = delete;

 private:
  const MapStore& store_;
};

bool MapStore::OthersWriting() const {
  if (Flock(writing_probe_, LOCK_EX | LOCK_NB) != 0) return errno == EWOULDBLOCK;
  (void)Flock(writing_probe_, LOCK_UN);
  return false;
}

void MapStore::WaitToRemove(std::unique_lock<std::mutex>& lock,
                            const std::function<bool()>& ready) const {
  while (true) {
    discarded_changed_.wait(lock, [&] { return closing_ || (writing_ == 0 && ready()); });
    if (closing_ || !OthersWriting()) return;
    // Another process's write ends without a word to this one: look again shortly.
    discarded_changed_.wait_for(lock, kOthersWritingPoll);
  }
}

void MapStore::RemoveDiscarded() const {
  std::unique_lock lock(discarded_mutex_);
  while (true) {
    WaitToRemove(lock, [&] { return !discarded_.empty() || !tiles_to_collect_.empty(); });
    if (!discarded_.empty()) {
      const fs::path trash = std::move(discarded_.front());
      discarded_.pop_front();
      removing_ = true;
      lock.unlock();
      // Left in trash/ for CollectGarbage (e.g. NFS files still open).
      RemoveAllInSlices(trash, [this] {
        std::unique_lock between(discarded_mutex_);
        WaitToRemove(between, [] { return true; });
      });
    } else if (!tiles_to_collect_.empty()) {
      const std::string id = *tiles_to_collect_.begin();
      tiles_to_collect_.erase(tiles_to_collect_.begin());
      removing_ = true;
      lock.unlock();
      CollectTiles(id);
    } else {
      return;  // Closing, and nothing left to do.
    }
    lock.lock();
    removing_ = false;
    discarded_changed_.notify_all();
  }
}

void MapStore::WaitForRemovals() const {
  std::unique_lock lock(discarded_mutex_);
  discarded_changed_.wait(
      lock, [&] { return discarded_.empty() && tiles_to_collect_.empty() && !removing_; });
}

fs::path MapStore::TerrainDir(const std::string& id, const std::string& terrain) const {
  return MapDir(id) / kTerrainsName / terrain;
}

fs::path MapStore::GraphsDir(const std::string& id, const std::string& terrain) const {
  return MapDir(id) / kGraphsName / terrain;
}

namespace {

// Puts the directory `target` (a `kind`: "terrain", "version"): `fill` writes its files into
// a fresh temporary directory, which is made durable and renamed into place. When `target`
// exists (another writer put the same content) that is success and nothing is written; its
// time is refreshed so that CollectGarbage does not take it for a dead writer's leftover
// before the caller names or publishes it.
ServiceStatus PutDirectory(const fs::path& tmp_dir, std::string_view kind, const fs::path& target,
                           const std::function<ServiceStatus(const fs::path&)>& fill) {
  std::error_code ec;
  if (fs::is_directory(target, ec)) {
    fs::last_write_time(target, fs::file_time_type::clock::now(), ec);
    return OkStatus();
  }
  const fs::path temporary = tmp_dir / UniqueName(kind);
  const auto fail = [&](ServiceError error) {
    std::error_code ignored;
    fs::remove_all(temporary, ignored);
    return error;
  };
  if (::mkdir(temporary.c_str(), 0755) != 0) {
    return Unavailable(temporary, "create the temporary directory", errno);
  }
  if (ServiceStatus filled = fill(temporary); !filled) return fail(std::move(filled).error());
  if (ServiceStatus synced = Sync(temporary); !synced) return fail(std::move(synced).error());

  // A deletion of the map may rename maps/<id> away between the mkdir and the rename: then
  // make it again (what is put after a deletion belongs to the map created next).
  const fs::path parent = target.parent_path();
  for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
    fs::create_directories(parent, ec);
    if (ec) return fail(Unavailable(parent, "create", ec));
    if (::rename(temporary.c_str(), target.c_str()) == 0) return Sync(parent);
    const int error = errno;
    // Another writer put the same content first: its bytes are the same.
    if (error == EEXIST || error == ENOTEMPTY) {
      fs::remove_all(temporary, ec);
      return OkStatus();
    }
    if (error != ENOENT) return fail(Unavailable(target, "rename into place", error));
  }
  return fail(Unavailable(target, "rename into place", ENOENT));
}

}  // namespace

ServiceStatus MapStore::PutTerrain(const std::string& id, const std::string& terrain,
                                   const CutTerrain& cut, TileWrites* writes) {
  const WriteScope writing(*this);
  if (ServiceStatus ok = CheckId(id); !ok) return ok;
  if (ServiceStatus ok = CheckTerrain(terrain); !ok) return ok;
  TileWrites ignored_writes;
  if (writes == nullptr) writes = &ignored_writes;
  *writes = {};
  const fs::path target = TerrainDir(id, terrain);
  std::error_code ec;
  if (fs::is_directory(target, ec)) {
    // Refreshed, so that CollectGarbage leaves it to the version about to name it.
    fs::last_write_time(target, fs::file_time_type::clock::now(), ec);
    return OkStatus();
  }
  const fs::path tiles_dir = MapDir(id) / kTilesName;
  // An edit writes a few tiles: an fsync each. A new map writes thousands: one flush of the
  // whole file system for all of them (which also waits for whatever else is being written
  // there, as a graph).
  const auto missing = std::count_if(cut.tiles.begin(), cut.tiles.end(), [&](const auto& tile) {
    return !fs::exists(tiles_dir / tile.first, ec);
  });
  const bool fsync_each = missing <= kMaxTilesSyncedEach;
  if (ServiceStatus written =
          WriteMissingTiles(tiles_dir, root_ / "tmp", cut.tiles, fsync_each, writes);
      !written) {
    return written;
  }
  if (writes->written > 0) {
    if (fsync_each) {
      if (ServiceStatus synced = Sync(tiles_dir); !synced) return synced;
    } else {
      const Fd fd(::open(tiles_dir.c_str(), O_RDONLY | O_CLOEXEC));
      if (!fd.valid() || ::syncfs(fd.get()) != 0) return Unavailable(tiles_dir, "syncfs", errno);
    }
  }
  // Under the map's lock, which collecting tiles takes: a tile collected since it was found
  // there is written again before the terrain listing it is renamed into place; one kept from
  // the base and collected since the base was read cannot be, and fails the edit.
  Result<MapLock> lock = MapLock::Acquire(MapDir(id), id, /*create=*/true);
  if (!lock) return std::move(lock).error();
  for (const std::string& name : cut.list.Names()) {  // Repeats cost a stat each.
    const fs::path path = tiles_dir / name;
    if (fs::exists(path, ec)) continue;
    const auto was_cut = std::find_if(cut.tiles.begin(), cut.tiles.end(),
                                      [&](const auto& tile) { return tile.first == name; });
    if (was_cut == cut.tiles.end()) {
      return MakeError(ServiceErrorCode::kMapChanged,
                       fmt::format("map '{}' changed while the edit was made: tile {} of the "
                                   "version it edited was collected (that version was pruned); "
                                   "make the edit again on the current version",
                                   id, name))
          .With("map_id", id)
          .With("missing_tile", name);
    }
    const std::string& bytes = was_cut->second;
    fs::create_directories(tiles_dir, ec);
    const fs::path temporary = root_ / "tmp" / UniqueName("tile");
    ServiceStatus written = WriteNewFile(temporary, bytes);
    if (written) written = RenameDurably(temporary, path);
    if (!written) return written;
    ++writes->written;
    writes->bytes_written += bytes.size();
  }
  const std::vector<std::string> names = cut.list.Names();
  writes->shared =
      static_cast<int>(std::set<std::string>(names.begin(), names.end()).size()) - writes->written;
  const std::string list = cut.list.Format();
  writes->bytes_written += list.size();
  writes->list_bytes = list.size();
  return PutDirectory(root_ / "tmp", "terrain", target,
                      [&](const fs::path& dir) { return WriteNewFile(dir / kTilesName, list); });
}

bool MapStore::HasTerrain(const std::string& id, const std::string& terrain) const {
  std::error_code ec;
  return CheckId(id).ok() && CheckTerrain(terrain).ok() &&
         fs::is_directory(TerrainDir(id, terrain), ec);
}

ServiceStatus MapStore::PutGraph(const std::string& id, const std::string& terrain,
                                 const SurfaceGraph& graph) {
  if (ServiceStatus ok = CheckId(id); !ok) return ok;
  if (ServiceStatus ok = CheckTerrain(terrain); !ok) return ok;
  const fs::path temporary = root_ / "tmp" / UniqueName("graph");
  const auto fail = [&](ServiceError error) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    return error;
  };
  if (Status saved = SaveGraph(graph, temporary.string()); !saved) {
    return fail(MakeError(ServiceErrorCode::kMapStoreUnavailable,
                          "map store: cannot write a graph: " + saved.error().message));
  }
  if (ServiceStatus synced = Sync(temporary); !synced) return fail(std::move(synced).error());
  const fs::path dir = GraphsDir(id, terrain);
  const fs::path target = dir / (SavedGraphKey(graph.params()) + kGraphExtension);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return fail(Unavailable(dir, "create", ec));
  // Over whatever is there: the same graph another replica kept, or one that no longer loads.
  if (::rename(temporary.c_str(), target.c_str()) != 0) {
    return fail(Unavailable(target, "rename into place", errno));
  }
  return Sync(dir);
}

bool MapStore::HasGraph(const std::string& id, const std::string& terrain,
                        const TraversabilityParams& params) const {
  if (!CheckId(id).ok() || !CheckTerrain(terrain).ok()) return false;
  std::error_code ec;
  return fs::exists(GraphsDir(id, terrain) / (SavedGraphKey(params) + kGraphExtension), ec);
}

Result<std::optional<SurfaceGraph>> MapStore::LoadGraph(const std::string& id,
                                                        const std::string& terrain,
                                                        const TerrainModel& model,
                                                        const TraversabilityParams& params) const {
  if (ServiceStatus ok = CheckId(id); !ok) return std::move(ok).error();
  if (ServiceStatus ok = CheckTerrain(terrain); !ok) return std::move(ok).error();
  const fs::path path = GraphsDir(id, terrain) / (SavedGraphKey(params) + kGraphExtension);
  std::error_code ec;
  if (!fs::exists(path, ec)) return std::optional<SurfaceGraph>();
  Expected<SurfaceGraph> graph = strata::LoadGraph(path.string(), model);
  if (graph) return std::optional<SurfaceGraph>(std::move(graph).value());
  if (!fs::exists(path, ec)) return std::optional<SurfaceGraph>();  // Pruned meanwhile.
  return MakeError(ServiceErrorCode::kMapCorrupted, "map store: " + graph.error().message)
      .With("map_id", id);
}

ServiceStatus MapStore::PutVersion(const std::string& id, const std::string& version,
                                   const std::string& terrain, const std::string& metadata) {
  const WriteScope writing(*this);
  if (ServiceStatus ok = CheckId(id); !ok) return ok;
  if (ServiceStatus ok = CheckVersion(version); !ok) return ok;
  if (ServiceStatus ok = CheckTerrain(terrain); !ok) return ok;
  // Refreshed first, so that CollectGarbage leaves it to the version about to name it.
  std::error_code ec;
  fs::last_write_time(TerrainDir(id, terrain), fs::file_time_type::clock::now(), ec);
  if (ec) {
    return MakeError(ServiceErrorCode::kMapVersionNotFound,
                     "map store: terrain " + terrain + " of map '" + id +
                         "' is not in the store (pruned meanwhile?): put it again")
        .With("map_id", id);
  }
  return PutDirectory(root_ / "tmp", "version", VersionDir(id, version), [&](const fs::path& dir) {
    ServiceStatus written = WriteNewFile(dir / kTerrainName, terrain + "\n");
    if (written) written = WriteNewFile(dir / kMetadataName, metadata);
    return written;
  });
}

ServiceStatus MapStore::PublishNew(const std::string& id, const std::string& version) {
  const WriteScope writing(*this);
  if (ServiceStatus ok = CheckId(id); !ok) return ok;
  if (ServiceStatus ok = CheckVersion(version); !ok) return ok;
  if (shared_heads_) return PublishNewShared(id, version);
  const fs::path map_dir = MapDir(id);
  Result<MapLock> lock = MapLock::Acquire(map_dir, id, /*create=*/true);
  if (!lock) return std::move(lock).error();
  Result<std::optional<std::vector<std::string>>> head = ReadHead(map_dir);
  if (!head) return std::move(head).error();
  if (head->has_value()) {
    const std::string& current = (**head).front();
    if (current == version) return OkStatus();
    return AlreadyExists(id, current);
  }
  if (!IsPut(id, version)) return NotPut(id, version);
  return WriteHead(root_ / "tmp", map_dir, {version});
}

ServiceStatus MapStore::PublishNewShared(const std::string& id, const std::string& version) {
  for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
    Result<MapHeads::Head> head = shared_heads_->Read(id);
    if (!head) return std::move(head).error();
    if (head->has_value()) {
      const std::string& current = (**head).front();
      if (current == version) return OkStatus();
      return AlreadyExists(id, current);
    }
    if (!IsPut(id, version)) return NotPut(id, version);
    Result<bool> swapped = shared_heads_->Swap(id, std::nullopt, std::vector{version});
    if (!swapped) return std::move(swapped).error();
    if (*swapped) return OkStatus();
  }
  return MakeError(ServiceErrorCode::kMapStoreUnavailable,
                   "map store: map '" + id + "' kept changing on other replicas: try again");
}

ServiceStatus MapStore::PublishUpdate(const std::string& id, const std::string& expected_current,
                                      const std::string& version, int keep_versions) {
  const WriteScope writing(*this);
  if (ServiceStatus ok = CheckId(id); !ok) return ok;
  if (ServiceStatus ok = CheckVersion(expected_current); !ok) return ok;
  if (ServiceStatus ok = CheckVersion(version); !ok) return ok;
  if (keep_versions < 1) return BadKeep(keep_versions);
  if (shared_heads_) return PublishUpdateShared(id, expected_current, version, keep_versions);
  const fs::path map_dir = MapDir(id);
  Result<MapLock> lock = MapLock::Acquire(map_dir, id, /*create=*/false);
  if (!lock) return std::move(lock).error();
  Result<std::optional<std::vector<std::string>>> head = ReadHead(map_dir);
  if (!head) return std::move(head).error();
  if (!head->has_value()) return MapLock::NotFound(id);
  std::vector<std::string> dropped;
  Result<std::optional<std::vector<std::string>>> next =
      UpdatedHead(id, **head, expected_current, version, keep_versions, &dropped);
  if (!next) return std::move(next).error();
  if (!next->has_value()) return OkStatus();
  if (ServiceStatus written = WriteHead(root_ / "tmp", map_dir, **next); !written) return written;
  // Only now that no head lists them: a reader that still loads one finds it gone (and is
  // told which versions are kept), never a head naming a missing version.
  DiscardVersions(id, dropped);
  return OkStatus();
}

Result<std::optional<std::vector<std::string>>> MapStore::UpdatedHead(
    const std::string& id, const std::vector<std::string>& kept,
    const std::string& expected_current, const std::string& version, int keep_versions,
    std::vector<std::string>* dropped) const {
  if (kept.front() == version) return std::optional<std::vector<std::string>>();
  if (kept.front() != expected_current) {
    // The version put for this change will never be published: no leftover stays behind,
    // unless the head lists it already (the same content published earlier).
    if (std::find(kept.begin(), kept.end(), version) == kept.end()) {
      DiscardVersions(id, {version});
    }
    return Changed(id, kept.front(), expected_current);
  }
  if (!IsPut(id, version)) return NotPut(id, version);
  return std::optional(NextHead(kept, version, keep_versions, dropped));
}

ServiceStatus MapStore::PublishUpdateShared(const std::string& id,
                                            const std::string& expected_current,
                                            const std::string& version, int keep_versions) {
  for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
    Result<MapHeads::Head> head = shared_heads_->Read(id);
    if (!head) return std::move(head).error();
    if (!head->has_value()) return MapLock::NotFound(id);
    std::vector<std::string> dropped;
    Result<std::optional<std::vector<std::string>>> next =
        UpdatedHead(id, **head, expected_current, version, keep_versions, &dropped);
    if (!next) return std::move(next).error();
    if (!next->has_value()) return OkStatus();
    Result<bool> swapped = shared_heads_->Swap(id, *head, *next);
    if (!swapped) return std::move(swapped).error();
    if (*swapped) {
      DiscardVersions(id, dropped);
      return OkStatus();
    }
  }
  return MakeError(ServiceErrorCode::kMapStoreUnavailable,
                   "map store: map '" + id + "' kept changing on other replicas: try again");
}

Result<std::vector<std::string>> MapStore::Versions(const std::string& id) const {
  if (ServiceStatus ok = CheckId(id); !ok) return std::move(ok).error();
  Result<std::optional<std::vector<std::string>>> head =
      shared_heads_ ? shared_heads_->Read(id) : ReadHead(MapDir(id));
  if (!head) return std::move(head).error();
  if (!head->has_value()) return MapLock::NotFound(id);
  return std::move(**head);
}

Result<std::string> MapStore::Current(const std::string& id) const {
  Result<std::vector<std::string>> versions = Versions(id);
  if (!versions) return std::move(versions).error();
  return versions->front();
}

ServiceError MapStore::MissingVersion(const std::string& id, const std::string& version) const {
  Result<std::vector<std::string>> kept = Versions(id);
  if (!kept) return std::move(kept).error();
  return MakeError(ServiceErrorCode::kMapVersionNotFound,
                   "map '" + id + "' has no version " + version + " (kept: " + JoinVersions(*kept) +
                       "): plan on one of those, or leave the version unset "
                       "for the current one")
      .With("map_id", id)
      .With("version", version);
}

namespace {

// The terrain a version's directory names; empty for a layout-1 version (no terrain file) or
// one that is not there (the caller tells which).
Result<std::string> ReadTerrainName(const fs::path& version_dir) {
  const fs::path path = version_dir / kTerrainName;
  Result<std::optional<std::string>> bytes = ReadFileIfExists(path);
  if (!bytes) return std::move(bytes).error();
  if (!bytes->has_value()) return std::string();
  std::string name = std::move(**bytes);
  if (!name.empty() && name.back() == '\n') name.pop_back();
  if (!MapStore::IsVersion(name)) {
    return MakeError(ServiceErrorCode::kMapCorrupted,
                     "map store: '" + path.string() +
                         "' does not name a terrain (edited by hand?): delete the map and create "
                         "it again");
  }
  return name;
}

}  // namespace

Result<fs::path> MapStore::VersionFile(const std::string& id, const std::string& version,
                                       const char* name) const {
  if (ServiceStatus ok = CheckId(id); !ok) return std::move(ok).error();
  if (ServiceStatus ok = CheckVersion(version); !ok) return std::move(ok).error();
  const fs::path dir = VersionDir(id, version);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return MissingVersion(id, version);
  if (std::strcmp(name, kMetadataName) == 0) return dir / name;
  Result<std::string> terrain = ReadTerrainName(dir);
  if (!terrain) return std::move(terrain).error();
  return terrain->empty() ? dir / name : TerrainDir(id, *terrain) / name;
}

Result<std::string> MapStore::TerrainOfVersion(const std::string& id,
                                               const std::string& version) const {
  if (ServiceStatus ok = CheckId(id); !ok) return std::move(ok).error();
  if (ServiceStatus ok = CheckVersion(version); !ok) return std::move(ok).error();
  const fs::path dir = VersionDir(id, version);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return MissingVersion(id, version);
  return ReadTerrainName(dir);
}

bool MapStore::IsPut(const std::string& id, const std::string& version) const {
  const fs::path dir = VersionDir(id, version);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return false;
  Result<std::string> terrain = ReadTerrainName(dir);
  return terrain && (terrain->empty() || fs::is_directory(TerrainDir(id, *terrain), ec));
}

namespace {

// The terrains the versions under `versions_dir` name (unreadable ones count as naming
// whatever they might: the caller then keeps every terrain).
std::optional<std::set<std::string>> NamedTerrains(const fs::path& versions_dir) {
  std::set<std::string> named;
  std::error_code ec;
  for (fs::directory_iterator it(versions_dir, ec), end; !ec && it != end; it.increment(ec)) {
    Result<std::string> terrain = ReadTerrainName(it->path());
    if (!terrain) return std::nullopt;
    if (!terrain->empty()) named.insert(std::move(terrain).value());
  }
  if (ec && ec != std::errc::no_such_file_or_directory) return std::nullopt;
  return named;
}

}  // namespace

int MapStore::DiscardVersions(const std::string& id,
                              const std::vector<std::string>& versions) const {
  int removed = 0;
  std::set<std::string> orphans;
  for (const std::string& version : versions) {
    Result<std::string> terrain = ReadTerrainName(VersionDir(id, version));
    if (terrain && !terrain->empty()) orphans.insert(*terrain);
    removed += Discard(VersionDir(id, version)) ? 1 : 0;
  }
  if (orphans.empty()) return removed;
  // A terrain goes with the last version naming it. One a writer names while this looks goes
  // too: its publish then finds the version not whole (IsPut) and the writer puts it again.
  const std::optional<std::set<std::string>> named = NamedTerrains(MapDir(id) / kVersionsName);
  if (!named) return removed;
  bool terrain_gone = false;
  for (const std::string& terrain : orphans) {
    if (named->contains(terrain)) continue;
    const bool gone = Discard(TerrainDir(id, terrain));
    terrain_gone |= gone;
    removed += gone ? 1 : 0;
    removed += Discard(GraphsDir(id, terrain)) ? 1 : 0;
  }
  if (terrain_gone) ScheduleTileCollection(id);
  return removed;
}

int MapStore::DiscardStaleTerrains(const std::string& id) const {
  int removed = 0;
  const fs::path terrains_dir = MapDir(id) / kTerrainsName;
  std::error_code ec;
  if (!fs::is_directory(terrains_dir, ec)) return 0;
  const std::optional<std::set<std::string>> named = NamedTerrains(MapDir(id) / kVersionsName);
  if (!named) return 0;
  std::vector<fs::path> unnamed;
  for (fs::directory_iterator it(terrains_dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!named->contains(it->path().filename().string())) unnamed.push_back(it->path());
  }
  // Graphs of a terrain no version names (a dead writer's, or kept while the terrain went).
  const fs::path graphs_dir = MapDir(id) / kGraphsName;
  for (fs::directory_iterator it(graphs_dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!named->contains(it->path().filename().string())) unnamed.push_back(it->path());
  }
  for (const fs::path& terrain : unnamed) {
    if (IsStale(terrain) && Discard(terrain)) ++removed;
  }
  return removed;
}

namespace {

// The list of tiles in terrain directory `dir`: nullopt when it has none (a layout-2 terrain,
// or one not there).
Result<std::optional<TerrainTiles>> ReadTileList(const fs::path& dir) {
  const fs::path path = dir / kTilesName;
  Result<std::optional<std::string>> text = ReadFileIfExists(path);
  if (!text) return std::move(text).error();
  if (!text->has_value()) return std::optional<TerrainTiles>();
  Result<TerrainTiles> tiles = TerrainTiles::Parse(**text, path);
  if (!tiles) return std::move(tiles).error();
  return std::optional<TerrainTiles>(std::move(tiles).value());
}

// The terrains of a map in place, each by its directory's name and inode (one put again after
// a removal is another directory), and the tiles they list.
struct ListedTiles {
  std::map<std::string, ino_t> terrains;
  std::unordered_set<std::string> names;
};

// The tiles the terrains of `map_dir` list, leaving out those in `known` (may be null; read
// before, unchanged since); nullopt when a list cannot be read (it might list anything).
std::optional<ListedTiles> ReadListedTiles(const fs::path& map_dir,
                                           const std::map<std::string, ino_t>* known) {
  ListedTiles listed;
  std::error_code ec;
  for (fs::directory_iterator it(map_dir / kTerrainsName, ec), end; !ec && it != end;
       it.increment(ec)) {
    struct stat status {};
    if (::stat(it->path().c_str(), &status) != 0) continue;  // Removed meanwhile.
    const std::string name = it->path().filename().string();
    listed.terrains.emplace(name, status.st_ino);
    if (known != nullptr) {
      const auto was = known->find(name);
      if (was != known->end() && was->second == status.st_ino) continue;
    }
    Result<std::optional<TerrainTiles>> tiles = ReadTileList(it->path());
    if (!tiles) return std::nullopt;
    if (!tiles->has_value()) continue;
    for (std::string& tile : (*tiles)->Names()) listed.names.insert(std::move(tile));
  }
  if (ec && ec != std::errc::no_such_file_or_directory) return std::nullopt;
  return listed;
}

}  // namespace

int MapStore::CollectTiles(const std::string& id) const {
  const fs::path map_dir = MapDir(id);
  const fs::path tiles_dir = map_dir / kTilesName;
  std::error_code ec;
  if (!fs::is_directory(tiles_dir, ec)) return 0;  // Not locked for nothing.
  // Found without the map's lock, which every publish of the map waits for: the tiles no
  // terrain in place lists (reading every list takes tens of milliseconds on a site).
  std::optional<ListedTiles> listed = ReadListedTiles(map_dir, nullptr);
  if (!listed) return 0;
  std::vector<fs::path> unlisted;
  for (fs::directory_iterator it(tiles_dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!listed->names.contains(it->path().filename().string())) unlisted.push_back(it->path());
  }
  if (unlisted.empty()) return 0;
  // Under the lock, in which a writer checks its tiles are there and renames its terrain in:
  // only the terrains put since are read. (The others' lists cannot have changed: a terrain is
  // named by its contents, and one put again is another directory.)
  Result<MapLock> lock = MapLock::Acquire(map_dir, id, /*create=*/false);
  if (!lock) return 0;
  std::optional<ListedTiles> since = ReadListedTiles(map_dir, &listed->terrains);
  if (!since) return 0;
  int removed = 0;
  for (const fs::path& tile : unlisted) {
    if (since->names.contains(tile.filename().string())) continue;
    std::error_code ignored;
    removed += fs::remove(tile, ignored) ? 1 : 0;
  }
  return removed;
}

Result<std::optional<TerrainTiles>> MapStore::TilesOfVersion(const std::string& id,
                                                             const std::string& version) const {
  Result<std::string> terrain = TerrainOfVersion(id, version);
  if (!terrain) return std::move(terrain).error();
  if (terrain->empty()) return std::optional<TerrainTiles>();  // Layout 1.
  const fs::path dir = TerrainDir(id, *terrain);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return MissingVersion(id, version);  // Pruned meanwhile.
  return ReadTileList(dir);
}

namespace {

ServiceError NoCloud(const std::string& id) {
  return MakeError(ServiceErrorCode::kEditNeedsCloud,
                   "map '" + id + "' was made from a saved model, which keeps no point " +
                       "cloud: create it from its point cloud to edit it")
      .With("map_id", id);
}

// The name messages give a version's tiled model or cloud.
std::string TiledName(const std::string& id, const std::string& version) {
  return "of version " + version + " of map '" + id + "'";
}

}  // namespace

Result<std::optional<OpenedTiles>> MapStore::OpenTiles(const std::string& id,
                                                       const std::string& version) const {
  Result<std::optional<TerrainTiles>> list = TilesOfVersion(id, version);
  if (!list) return std::move(list).error();
  if (!list->has_value()) return std::optional<OpenedTiles>();
  const fs::path dir = MapDir(id) / kTilesName;
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT && !IsPut(id, version)) return MissingVersion(id, version);
    return Unavailable(dir, "open", errno);
  }
  return std::optional<OpenedTiles>(
      OpenedTiles{std::make_shared<const OpenedMapFile>(fd, dir), std::move(**list)});
}

ServiceError MapStore::TilesFailed(const std::string& id, const std::string& version,
                                   ServiceError error) const {
  error.With("map_id", id).With("version", version);
  if (error.code != ServiceError::Code(ServiceErrorCode::kMapVersionNotFound)) return error;
  // A tile gone: its version was pruned meanwhile, or the tile was removed by hand.
  if (!IsPut(id, version)) return MissingVersion(id, version);
  return MakeError(ServiceErrorCode::kMapCorrupted,
                   error.message + "; version " + version + " of map '" + id +
                       "' lists it: delete the map and create it again")
      .With("map_id", id)
      .With("version", version);
}

Result<std::shared_ptr<const TerrainModel>> MapStore::LoadModel(
    const std::string& id, const std::string& version,
    const std::shared_ptr<const TerrainModel>& held, const std::string& held_version,
    std::optional<CellBox>* changed_from_held) const {
  if (changed_from_held != nullptr) changed_from_held->reset();
  Result<std::optional<OpenedTiles>> tiles = OpenTiles(id, version);
  if (!tiles) return std::move(tiles).error();
  if (tiles->has_value()) {
    // The held version's list; none (a layout without tiles, pruned meanwhile): read all.
    std::optional<HeldTerrain> from;
    if (held != nullptr) {
      Result<std::optional<TerrainTiles>> list = TilesOfVersion(id, held_version);
      if (list && list->has_value()) from = HeldTerrain{held, std::move(**list)};
    }
    Result<std::shared_ptr<const TerrainModel>> model = LoadTiledModel(
        **tiles, TiledName(id, version), {}, from ? &*from : nullptr, changed_from_held);
    if (!model) return TilesFailed(id, version, std::move(model).error());
    return model;
  }
  Result<fs::path> path = VersionFile(id, version, kModelName);
  if (!path) return std::move(path).error();
  Expected<std::shared_ptr<const TerrainModel>> model = strata::LoadModel(path->string());
  if (model) return std::move(*model);
  std::error_code ec;
  // Pruned or deleted while this read it.
  if (!fs::exists(*path, ec)) return MissingVersion(id, version);
  return MakeError(ServiceErrorCode::kMapCorrupted,
                   "map store: version " + version + " of map '" + id + "' cannot be loaded: " +
                       model.error().message + " (delete the map and create it again)")
      .With("map_id", id)
      .With("version", version);
}

Result<PointCloud> MapStore::LoadCloud(const std::string& id, const std::string& version) const {
  Result<std::optional<OpenedTiles>> tiles = OpenTiles(id, version);
  if (!tiles) return std::move(tiles).error();
  if (tiles->has_value()) {
    if ((*tiles)->list.cloud.empty()) return NoCloud(id);
    Result<PointCloud> cloud = LoadTiledCloud(**tiles, TiledName(id, version));
    if (!cloud) return TilesFailed(id, version, std::move(cloud).error());
    return cloud;
  }
  Result<fs::path> path = VersionFile(id, version, kCloudName);
  if (!path) return std::move(path).error();
  // The cloud passed the server's limits when it was accepted; these only guard the reader.
  CloudLoadLimits limits;
  limits.max_points = std::numeric_limits<std::size_t>::max();
  limits.max_file_bytes = std::numeric_limits<std::size_t>::max();
  limits.max_abs_coordinate_m = std::numeric_limits<double>::max();
  Expected<LoadedCloud> cloud = LoadPointCloud(path->string(), limits);
  if (cloud) return std::move(cloud->points);
  std::error_code ec;
  if (!fs::exists(*path, ec)) {
    if (fs::is_directory(path->parent_path(), ec)) {
      return NoCloud(id);
    }
    return MissingVersion(id, version);
  }
  return MakeError(ServiceErrorCode::kMapCorrupted,
                   "map store: the cloud of version " + version + " of map '" + id +
                       "' cannot be loaded: " + cloud.error().message +
                       " (delete the map and create it again)")
      .With("map_id", id)
      .With("version", version);
}

Result<std::shared_ptr<const OpenedMapFile>> MapStore::OpenVersionFile(const std::string& id,
                                                                       const std::string& version,
                                                                       const char* name) const {
  Result<fs::path> path = VersionFile(id, version, name);
  if (!path) return std::move(path).error();
  const int fd = open(path->c_str(), O_RDONLY | O_CLOEXEC);
  if (fd >= 0) return std::make_shared<const OpenedMapFile>(fd, *path);
  const int error = errno;
  std::error_code ec;
  if (error == ENOENT && std::strcmp(name, kCloudName) == 0 &&
      fs::is_directory(path->parent_path(), ec)) {
    return NoCloud(id);
  }
  if (error == ENOENT) return MissingVersion(id, version);
  return Unavailable(*path, "open", error);
}

Result<VersionFiles> MapStore::OpenVersion(const std::string& id,
                                           const std::string& version) const {
  Result<std::optional<OpenedTiles>> tiles = OpenTiles(id, version);
  if (!tiles) return std::move(tiles).error();
  if (tiles->has_value()) {
    if ((*tiles)->list.cloud.empty()) return NoCloud(id);
    return VersionFiles{nullptr, nullptr, std::move(*tiles)};
  }
  Result<std::shared_ptr<const OpenedMapFile>> cloud = OpenVersionFile(id, version, kCloudName);
  if (!cloud) return std::move(cloud).error();
  Result<std::shared_ptr<const OpenedMapFile>> model = OpenVersionFile(id, version, kModelName);
  if (!model) return std::move(model).error();
  return VersionFiles{std::move(cloud).value(), std::move(model).value(), std::nullopt};
}

Result<std::string> MapStore::LoadMetadata(const std::string& id,
                                           const std::string& version) const {
  Result<fs::path> path = VersionFile(id, version, kMetadataName);
  if (!path) return std::move(path).error();
  Result<std::optional<std::string>> bytes = ReadFileIfExists(*path);
  if (!bytes) return std::move(bytes).error();
  if (!bytes->has_value()) return MissingVersion(id, version);
  return std::move(**bytes);
}

Result<std::vector<std::string>> MapStore::ListIds(const std::string& after_id, int max) const {
  if (shared_heads_) {
    Result<std::vector<std::string>> all = shared_heads_->Ids();
    if (!all) return std::move(all).error();
    std::vector<std::string> ids;
    for (std::string& id : *all) {
      if (max > 0 && ids.size() >= static_cast<std::size_t>(max)) break;
      if (id > after_id) ids.push_back(std::move(id));
    }
    return ids;
  }
  const fs::path maps = root_ / "maps";
  std::vector<std::string> candidates;
  std::error_code ec;
  for (fs::directory_iterator it(maps, ec), end; !ec && it != end; it.increment(ec)) {
    std::string id = it->path().filename().string();
    if (id > after_id && CheckId(id).ok()) candidates.push_back(std::move(id));
  }
  if (ec) return Unavailable(maps, "list", ec);
  std::sort(candidates.begin(), candidates.end());
  std::vector<std::string> ids;
  for (std::string& id : candidates) {
    if (max > 0 && ids.size() >= static_cast<std::size_t>(max)) break;
    if (fs::exists(MapDir(id) / kHeadName, ec)) ids.push_back(std::move(id));
  }
  return ids;
}

ServiceStatus MapStore::Delete(const std::string& id) {
  if (ServiceStatus ok = CheckId(id); !ok) return ok;
  if (shared_heads_) return DeleteShared(id);
  const fs::path map_dir = MapDir(id);
  Result<MapLock> lock = MapLock::Acquire(map_dir, id, /*create=*/false);
  if (!lock) return std::move(lock).error();
  Result<std::optional<std::vector<std::string>>> head = ReadHead(map_dir);
  // A corrupted head is still deleted: that is the way out the error messages offer.
  if (!head && head.error().code != ServiceError::Code(ServiceErrorCode::kMapCorrupted)) {
    return std::move(head).error();
  }
  if (head && !head->has_value()) return MapLock::NotFound(id);
  if (!Discard(map_dir)) return Unavailable(map_dir, "move to trash/", errno);
  return OkStatus();
}

ServiceStatus MapStore::DeleteShared(const std::string& id) {
  for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
    Result<MapHeads::Head> head = shared_heads_->Read(id);
    if (!head) return std::move(head).error();
    if (!head->has_value()) return MapLock::NotFound(id);
    Result<bool> swapped = shared_heads_->Swap(id, *head, std::nullopt);
    if (!swapped) return std::move(swapped).error();
    if (*swapped) {
      // Gone for everyone with its head; its files follow (or CollectGarbage takes them).
      Discard(MapDir(id));
      return OkStatus();
    }
  }
  return MakeError(ServiceErrorCode::kMapStoreUnavailable,
                   "map store: map '" + id + "' kept changing on other replicas: try again");
}

namespace {

// The entries of `dir` (none when it cannot be listed).
std::vector<fs::path> Entries(const fs::path& dir) {
  std::vector<fs::path> paths;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    paths.push_back(it->path());
  }
  return paths;
}

}  // namespace

int MapStore::CollectGarbage() {
  int removed = 0;
  const auto remove = [&](const fs::path& path) {
    std::error_code error;
    fs::remove_all(path, error);
    removed += error ? 0 : 1;
  };
  for (const fs::path& path : Entries(root_ / "trash")) remove(path);
  for (const fs::path& path : Entries(root_ / "tmp")) {
    if (IsStale(path)) remove(path);
  }
  if (shared_heads_) {
    removed += CollectSharedGarbage();
  } else {
    removed += CollectFileHeadGarbage();
  }
  // Tiles no terrain lists: a writer killed between its tiles and its terrain, or the
  // collection after a terrain's removal never ran. Last: locking makes a lock file, which
  // refreshes a map directory's age.
  for (const fs::path& map_dir : Entries(root_ / "maps")) {
    const std::string id = map_dir.filename().string();
    if (CheckId(id).ok()) removed += CollectTiles(id);
  }
  return removed;
}

int MapStore::CollectFileHeadGarbage() {
  int removed = 0;
  std::error_code ec;
  for (const fs::path& map_dir : Entries(root_ / "maps")) {
    const std::string id = map_dir.filename().string();
    if (!CheckId(id).ok()) continue;
    // Stale leftovers only, and under the map's lock so that no publisher is between its
    // check of a version and its new head.
    const fs::path versions_dir = map_dir / kVersionsName;
    // The map directory's age is taken before locking: locking may create its lock file.
    const bool map_dir_stale = IsStale(map_dir);
    bool any_stale = map_dir_stale;
    for (const fs::path& version : Entries(versions_dir)) any_stale |= IsStale(version);
    for (const fs::path& terrain : Entries(map_dir / kTerrainsName)) any_stale |= IsStale(terrain);
    for (const fs::path& graphs : Entries(map_dir / kGraphsName)) any_stale |= IsStale(graphs);
    if (!any_stale) continue;
    Result<MapLock> lock = MapLock::Acquire(map_dir, id, /*create=*/false);
    if (!lock) continue;
    Result<std::optional<std::vector<std::string>>> head = ReadHead(map_dir);
    if (!head) continue;
    if (!head->has_value()) {
      // No head: a writer died before publishing, unless versions/ changed lately (one
      // renamed in by a writer that is about to publish).
      const bool versions_stale = !fs::exists(versions_dir, ec) || IsStale(versions_dir);
      if (map_dir_stale && versions_stale && Discard(map_dir)) ++removed;
      continue;
    }
    const std::vector<std::string>& kept = **head;
    for (const fs::path& version : Entries(versions_dir)) {
      const bool listed =
          std::find(kept.begin(), kept.end(), version.filename().string()) != kept.end();
      if (!listed && IsStale(version) && Discard(version)) ++removed;
    }
    removed += DiscardStaleTerrains(id);
  }
  return removed;
}

int MapStore::CollectSharedGarbage() {
  int removed = 0;
  std::error_code ec;
  for (fs::directory_iterator it(root_ / "maps", ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path map_dir = it->path();
    const std::string id = map_dir.filename().string();
    if (!CheckId(id).ok()) continue;
    Result<MapHeads::Head> head = shared_heads_->Read(id);
    if (!head) continue;  // Unknown now: keep everything.
    if (!head->has_value()) {
      if (IsStale(map_dir) && IsStale(map_dir / kVersionsName) && Discard(map_dir)) ++removed;
      continue;
    }
    const std::vector<std::string>& kept = **head;
    std::error_code versions_ec;
    std::vector<fs::path> versions;
    for (fs::directory_iterator v(map_dir / kVersionsName, versions_ec), v_end;
         !versions_ec && v != v_end; v.increment(versions_ec)) {
      versions.push_back(v->path());
    }
    for (const fs::path& version : versions) {
      const bool listed =
          std::find(kept.begin(), kept.end(), version.filename().string()) != kept.end();
      if (!listed && IsStale(version) && Discard(version)) ++removed;
    }
    removed += DiscardStaleTerrains(id);
  }
  return removed;
}

}  // namespace strata::server
