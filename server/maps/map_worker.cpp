#include "maps/map_worker.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "common/log.hpp"
#include "maps/map_worker_protocol.hpp"
#include "strata/io/saved_model.hpp"

extern char** environ;

namespace strata::server {
namespace {

namespace fs = std::filesystem;

// The worker's standard error kept for the log: its end says why it died.
constexpr std::size_t kStderrKeptBytes = 4096;
// Longest report line read; a longer one is cut (it is a message, not data).
constexpr std::size_t kMaxReportLineBytes = 64 * 1024;
// How often the worker's caller is asked whether to stop while the worker is silent.
constexpr int kPollPeriodMs = 100;

std::string ErrnoText(int error) { return std::system_category().message(error); }

// A directory of one job, removed with what it holds when the job ends.
class JobDirectory {
 public:
  static Result<JobDirectory> Create(const fs::path& parent) {
    std::string pattern = (parent / "strata-map-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) {
      const int error = errno;
      return MakeError(ServiceErrorCode::kInternal, "cannot create a job directory under '" +
                                                        parent.string() + "': " + ErrnoText(error) +
                                                        " (TMPDIR sets where)");
    }
    return JobDirectory(pattern);
  }
  JobDirectory(JobDirectory&& other) noexcept : path_(std::exchange(other.path_, {})) {}
  JobDirectory& operator=(JobDirectory&&) = delete;
  ~JobDirectory() {
    std::error_code ignored;
    if (!path_.empty()) fs::remove_all(path_, ignored);
  }
  const fs::path& path() const { return path_; }

 private:
  explicit JobDirectory(fs::path path) : path_(std::move(path)) {}
  fs::path path_;
};

// A pipe's two ends, closed when it goes.
struct Pipe {
  int read = -1;
  int write = -1;
  Pipe() {
    int ends[2];
    if (pipe2(ends, O_CLOEXEC) == 0) {
      read = ends[0];
      write = ends[1];
    }
  }
  Pipe(const Pipe&) = delete;
  Pipe& operator=(const Pipe&) = delete;
  ~Pipe() {
    CloseRead();
    CloseWrite();
  }
  void CloseRead() { read = (read >= 0 ? close(read) : 0, -1); }
  void CloseWrite() { write = (write >= 0 ? close(write) : 0, -1); }
};

// The worker's job for `job`; uploaded points are written to `directory` (and freed).
// Writes `contents` to the job's file `path` (`what` names it in the error).
ServiceStatus WriteJobFile(const std::string& path, const std::string& contents, const char* what) {
  std::ofstream file(path, std::ios::binary);
  file << contents;
  file.close();
  if (!file) {
    return MakeError(ServiceErrorCode::kInternal,
                     std::string("cannot write the ") + what + " for a map worker to '" + path +
                         "' (is the scratch directory full? TMPDIR sets where)");
  }
  return OkStatus();
}

Result<WorkerJob> WorkerJobOf(MapBuildJob& job, const MapWorkerOptions& options,
                              const fs::path& directory) {
  WorkerJob worker;
  if (const auto* file = std::get_if<FileMapSource>(&job.source)) {
    worker.kind = WorkerJob::Source::kFile;
    worker.source = file->requested_path;
  } else if (const auto* scene = std::get_if<SceneMapSource>(&job.source)) {
    worker.kind = WorkerJob::Source::kScene;
    worker.source = FormatSceneSource(*scene);
  } else if (const auto* edit = std::get_if<EditSource>(&job.source)) {
    worker.kind = WorkerJob::Source::kEdit;
    worker.source = (directory / kWorkerEditsFile).string();
    if (ServiceStatus written = WriteJobFile(worker.source, FormatEdits(edit->edits), "edits");
        !written) {
      return std::move(written).error();
    }
    if (edit->files.tiles) {
      worker.tiled = true;
      if (ServiceStatus written = WriteJobFile((directory / kWorkerTilesFile).string(),
                                               edit->files.tiles->list.Format(), "tiles");
          !written) {
        return std::move(written).error();
      }
    }
  } else {
    worker.kind = WorkerJob::Source::kPoints;
    worker.source = (directory / kWorkerUploadFile).string();
    PointCloud& points = std::get<UploadMapSource>(job.source).points;
    if (Status written = SavePcd(points, worker.source); !written) {
      return ServiceError::FromPlanner(written.error());
    }
    PointCloud().swap(points);  // The worker reads them now: this copy goes.
    std::get<UploadMapSource>(job.source).reservation.reset();
  }
  worker.saved_model = job.saved_model;
  worker.keep_cloud = job.keep_cloud;
  worker.config = job.config;
  worker.limits = job.limits;
  worker.out_dir = directory;
  worker.memory_bytes = options.memory_bytes;
  worker.cpu_s = options.cpu_s;
  return worker;
}

// The descriptors the worker of `job` inherits, each at the number the protocol gives it.
std::vector<std::pair<int, int>> InheritedFiles(const MapBuildJob& job) {
  if (const auto* file = std::get_if<FileMapSource>(&job.source)) {
    return {{file->file->fd(), kWorkerSourceFd}};
  }
  if (const auto* edit = std::get_if<EditSource>(&job.source)) {
    if (edit->files.tiles) return {{edit->files.tiles->dir->fd(), kWorkerSourceFd}};
    return {{edit->files.cloud->fd(), kWorkerSourceFd},
            {edit->files.model->fd(), kWorkerBaseModelFd}};
  }
  return {};
}

// Starts the worker with `args`, its output and errors on the pipes and each of `inherited`'s
// descriptors at its number.
Result<pid_t> Spawn(const fs::path& program, const std::vector<std::string>& args,
                    const std::vector<std::pair<int, int>>& inherited, Pipe& out, Pipe& err) {
  if (out.read < 0 || err.read < 0) {
    const int error = errno;
    return MakeError(ServiceErrorCode::kInternal,
                     "cannot make a pipe to a map worker: " + ErrnoText(error));
  }
  std::vector<char*> argv;
  std::string name = program.string();
  argv.push_back(name.data());
  std::vector<std::string> owned = args;
  for (std::string& arg : owned) argv.push_back(arg.data());
  argv.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, out.write, STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, err.write, STDERR_FILENO);
  for (const auto& [fd, number] : inherited) {
    posix_spawn_file_actions_adddup2(&actions, fd, number);
  }
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  // The server blocks SIGTERM and SIGINT in every thread (main.cpp) and the worker would
  // inherit that; it gets the default mask and handlers, and a process group of its own so a
  // terminal's Ctrl-C reaches the server, which stops it.
  sigset_t none;
  sigset_t all;
  sigemptyset(&none);
  sigfillset(&all);
  posix_spawnattr_setsigmask(&attributes, &none);
  posix_spawnattr_setsigdefault(&attributes, &all);
  posix_spawnattr_setpgroup(&attributes, 0);
  posix_spawnattr_setflags(&attributes,
                           POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETPGROUP);
  std::vector<std::string> environment = WorkerEnvironment(environ);
  std::vector<char*> envp;
  envp.reserve(environment.size() + 1);
  for (std::string& entry : environment) envp.push_back(entry.data());
  envp.push_back(nullptr);
  pid_t pid = -1;
  const int error =
      posix_spawn(&pid, name.c_str(), &actions, &attributes, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);
  out.CloseWrite();
  err.CloseWrite();
  if (error != 0) {
    return MakeError(ServiceErrorCode::kInternal, "cannot start the map worker '" + name +
                                                      "': " + ErrnoText(error) +
                                                      " (--map-worker names it)");
  }
  return pid;
}

// What the worker said and how it ended.
struct Outcome {
  std::optional<WorkerReport> loaded;
  std::optional<Error> failure;
  bool done = false;
  std::string version;              // With done.
  std::optional<EditFigures> edit;  // With done, for an edit.
  bool killed = false;              // By us, because should_stop asked.
  int status = 0;                   // waitpid's.
  std::string stderr_tail;
};

// Reads the worker's reports until it closes its output, passing them to `monitor`, and kills
// it when monitor.should_stop says so; then reaps it.
Outcome Follow(pid_t pid, Pipe& out, Pipe& err, const BuildMonitor& monitor) {
  Outcome outcome;
  std::string line;
  std::array<char, 16 * 1024> buffer{};
  while (out.read >= 0 || err.read >= 0) {
    if (!outcome.killed && monitor.should_stop && monitor.should_stop()) {
      kill(pid, SIGKILL);
      outcome.killed = true;
    }
    pollfd fds[2] = {{out.read, POLLIN, 0}, {err.read, POLLIN, 0}};
    if (poll(fds, 2, kPollPeriodMs) < 0 && errno != EINTR) break;
    if (err.read >= 0 && (fds[1].revents & (POLLIN | POLLHUP | POLLERR)) != 0) {
      const ssize_t n = read(err.read, buffer.data(), buffer.size());
      if (n <= 0) {
        err.CloseRead();
      } else {
        outcome.stderr_tail.append(buffer.data(), static_cast<std::size_t>(n));
        if (outcome.stderr_tail.size() > 2 * kStderrKeptBytes) {
          outcome.stderr_tail.erase(0, outcome.stderr_tail.size() - kStderrKeptBytes);
        }
      }
    }
    if (out.read < 0 || (fds[0].revents & (POLLIN | POLLHUP | POLLERR)) == 0) continue;
    const ssize_t n = read(out.read, buffer.data(), buffer.size());
    if (n <= 0) {
      out.CloseRead();
      continue;
    }
    for (const char c : std::string_view(buffer.data(), static_cast<std::size_t>(n))) {
      if (c != '\n') {
        if (line.size() < kMaxReportLineBytes) line.push_back(c);
        continue;
      }
      const std::optional<WorkerReport> report = ParseWorkerReport(line);
      line.clear();
      if (!report || outcome.killed) continue;
      switch (report->kind) {
        case WorkerReport::Kind::kLoaded:
          outcome.loaded = report;
          if (monitor.on_loaded) {
            monitor.on_loaded(report->raw_points, report->dropped_nonfinite, report->load_s);
          }
          break;
        case WorkerReport::Kind::kProgress:
          if (monitor.on_progress) monitor.on_progress(report->step, report->fraction);
          break;
        case WorkerReport::Kind::kFailed: outcome.failure = report->error; break;
        case WorkerReport::Kind::kDone:
          outcome.done = true;
          outcome.version = report->version;
          outcome.edit = report->edit;
          break;
      }
    }
  }
  while (waitpid(pid, &outcome.status, 0) < 0 && errno == EINTR) {
  }
  if (outcome.stderr_tail.size() > kStderrKeptBytes) {
    outcome.stderr_tail.erase(0, outcome.stderr_tail.size() - kStderrKeptBytes);
  }
  return outcome;
}

std::string SignalText(int signal_number) {
  const char* abbreviation = sigabbrev_np(signal_number);
  const char* description = strsignal(signal_number);
  return (abbreviation != nullptr ? "SIG" + std::string(abbreviation)
                                  : fmt::format("signal {}", signal_number)) +
         (description != nullptr ? std::string(", ") + description : std::string());
}

std::string MiB(std::uint64_t bytes) { return fmt::format("{} MiB", bytes >> 20); }

// The failure an unsuccessful end of the worker means.
ServiceError FailureOf(const Outcome& outcome, const MapBuildJob& job,
                       const MapWorkerOptions& options) {
  if (outcome.killed) return MakeError(ErrorCode::kCancelled, "the map's creation was stopped");
  const int status = outcome.status;
  if (WIFEXITED(status) && WEXITSTATUS(status) == kWorkerExitFailed && outcome.failure) {
    return ServiceError::FromPlanner(*outcome.failure);
  }
  const bool edit = std::holds_alternative<EditSource>(job.source);
  const std::string what = job.saved_model  ? "loading the saved model"
                           : edit           ? (outcome.loaded ? "reassessing the edited terrain"
                                                              : "reading the map's current version")
                           : outcome.loaded ? "assessing the terrain"
                                            : "reading the points";
  if (WIFEXITED(status) && WEXITSTATUS(status) == kWorkerExitOutOfMemory) {
    return MakeError(ErrorCode::kResourceExhausted,
                     fmt::format("{} needed more memory than a map may use "
                                 "(--max-assessment-memory {}): use a coarser "
                                 "terrain.resolution_m or a smaller cloud, or raise the limit",
                                 what, MiB(options.memory_bytes)));
  }
  if (WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) {
    // Not sent by this server (outcome.killed says so). All that is known is the signal.
    return MakeError(ErrorCode::kResourceExhausted,
                     fmt::format("the map worker was killed by signal 9 (SIGKILL) while {}, not "
                                 "by this server: the kernel's out-of-memory killer sends it "
                                 "when the machine or the server's container runs out of memory "
                                 "(a worker may use up to --max-assessment-memory {}), and so "
                                 "can an operator; the kernel log (dmesg) says which",
                                 what, MiB(options.memory_bytes)));
  }
  if (WIFSIGNALED(status) && WTERMSIG(status) == SIGXCPU) {
    return MakeError(ErrorCode::kResourceExhausted,
                     fmt::format("{} used the {} s of CPU time a map may use: use a coarser "
                                 "terrain.resolution_m or a smaller cloud, or raise "
                                 "--max-assessment-time-s",
                                 what, static_cast<long>(options.cpu_s)));
  }
  if (WIFSIGNALED(status)) {
    return MakeError(ErrorCode::kMapLoadFailed,
                     "the map worker crashed (" + SignalText(WTERMSIG(status)) + ") while " + what +
                         (outcome.loaded ? std::string()
                                         : ": the source is probably malformed in a way its "
                                           "reader does not check; convert it (e.g. to a "
                                           "binary PCD) and try again") +
                         "; the server is unaffected");
  }
  return MakeError(ServiceErrorCode::kInternal,
                   fmt::format("the map worker ended with exit code {} while {} without saying "
                               "why (the server's log has its output)",
                               WIFEXITED(status) ? WEXITSTATUS(status) : -1, what));
}

// The map the worker left in `directory`.
Result<BuiltMap> ReadResult(const Outcome& outcome, const MapBuildJob& job,
                            const fs::path& directory) {
  BuiltMap built;
  if (CutsTiles(job)) {
    // The tiles the edit changed; the caller joins the model from them and the base's.
    Expected<CutTerrain> cut = ReadCutTerrain(directory / kWorkerCutDir);
    if (!cut) return ServiceError::FromPlanner(cut.error());
    built.cut = std::move(cut).value();
  } else {
    Expected<std::shared_ptr<const TerrainModel>> model =
        LoadModel((directory / kWorkerModelFile).string());
    if (!model) return ServiceError::FromPlanner(model.error());
    built.model = std::move(model).value();
  }
  if (job.keep_cloud && !built.cut) {
    Expected<LoadedCloud> cloud =
        LoadPointCloud((directory / kWorkerCloudFile).string(), job.limits);
    if (!cloud) return ServiceError::FromPlanner(cloud.error());
    built.cloud = std::move(cloud->points);
  }
  if (outcome.loaded) {
    built.raw_point_count = outcome.loaded->raw_points;
    built.dropped_nonfinite = outcome.loaded->dropped_nonfinite;
    built.load_s = outcome.loaded->load_s;
  }
  built.version = outcome.version;
  built.edit = outcome.edit;
  return built;
}

Result<BuiltMap> BuildInWorker(const MapWorkerOptions& options, MapBuildJob job,
                               const BuildMonitor& monitor) {
  Result<JobDirectory> directory = JobDirectory::Create(options.scratch_dir);
  if (!directory.ok()) return std::move(directory).error();
  Result<WorkerJob> worker = WorkerJobOf(job, options, directory->path());
  if (!worker.ok()) return std::move(worker).error();
  Pipe out;
  Pipe err;
  Result<pid_t> pid =
      Spawn(options.program, WorkerArguments(worker.value()), InheritedFiles(job), out, err);
  if (!pid.ok()) return std::move(pid).error();
  const Outcome outcome = Follow(pid.value(), out, err, monitor);
  if (!outcome.stderr_tail.empty()) {
    LogWarning("map_worker_output")
        .Add("pid", static_cast<long long>(pid.value()))
        .Add("message", outcome.stderr_tail);
  }
  const bool succeeded = !outcome.killed && WIFEXITED(outcome.status) &&
                         WEXITSTATUS(outcome.status) == kWorkerExitDone && outcome.done;
  if (!succeeded) return FailureOf(outcome, job, options);
  return ReadResult(outcome, job, directory->path());
}

}  // namespace

MapBuilder MapWorkerBuilder(MapWorkerOptions options) {
  return [options = std::move(options)](MapBuildJob job, const BuildMonitor& monitor) {
    return BuildInWorker(options, std::move(job), monitor);
  };
}

fs::path MapWorkerBesideThisProgram() {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  if (error) return {};
  const fs::path worker = self.parent_path() / "strata-map-worker";
  return fs::exists(worker, error) ? worker : fs::path();
}

std::vector<std::string> WorkerEnvironment(char** parent) {
  constexpr std::string_view kTunables = "GLIBC_TUNABLES=";
  std::vector<std::string> environment;
  bool tuned = false;
  for (char** entry = parent; *entry != nullptr; ++entry) {
    environment.emplace_back(*entry);
    tuned = tuned || environment.back().starts_with(kTunables);
  }
  if (!tuned) environment.push_back(std::string(kTunables) + "glibc.malloc.hugetlb=1");
  return environment;
}

}  // namespace strata::server
