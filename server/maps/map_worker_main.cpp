// strata-map-worker: makes one map for strata-server in a process of its own, so that a file
// that crashes a reader (Debian's PCL aborts on some malformed files), or a cloud that needs
// more memory or CPU time than allowed, fails that map and not the server. The server starts
// it (map_worker.hpp); the command line, the report lines and the exit codes are
// map_worker_protocol.hpp's. Not meant to be run by hand.
#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <iterator>
#include <mutex>
#include <new>
#include <string>

#include "maps/map_build.hpp"
#include "maps/map_worker_protocol.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/io/saved_model.hpp"
#include "strata/scenes/map_source.hpp"

namespace {

using strata::server::WorkerJob;
using strata::server::WorkerReport;

// One whole line on standard output, which the server reads as it comes.
void Send(const WorkerReport& report) {
  const std::string line = strata::server::FormatWorkerReport(report);
  for (std::size_t sent = 0; sent < line.size();) {
    const ssize_t n = write(STDOUT_FILENO, line.data() + sent, line.size() - sent);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) std::_Exit(strata::server::kWorkerExitFailed);  // The server is gone.
    sent += static_cast<std::size_t>(n);
  }
}

void SendFailure(strata::Error error) {
  WorkerReport report;
  report.kind = WorkerReport::Kind::kFailed;
  report.error = std::move(error);
  Send(report);
}

[[noreturn]] void OutOfMemory() { std::_Exit(strata::server::kWorkerExitOutOfMemory); }

// An exception that escaped a thread ends here (an OpenMP region cannot pass it on): a
// bad_alloc is the memory limit, anything else a crash.
[[noreturn]] void OnTerminate() {
  if (const std::exception_ptr escaped = std::current_exception()) {
    try {
      std::rethrow_exception(escaped);
    } catch (const std::bad_alloc&) {
      OutOfMemory();
    } catch (...) {
    }
  }
  std::abort();
}

// Private writable memory mapped now (VmData) [bytes]: the libraries' and, in a sanitised
// build, the sanitiser's own. The memory limit is counted from here.
std::uint64_t MappedDataBytes() {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == "VmData:") {
      std::uint64_t kib = 0;
      status >> kib;
      return kib * 1024;
    }
    status.ignore(1 << 16, '\n');
  }
  return 0;
}

void LimitSelf(const WorkerJob& job) {
  const rlimit no_core{0, 0};  // A crash must not write a core file the size of a map.
  setrlimit(RLIMIT_CORE, &no_core);
  if (job.cpu_s > 0) {
    // SIGXCPU at the soft limit, SIGKILL at the hard one should that be caught.
    const auto soft = static_cast<rlim_t>(std::ceil(job.cpu_s));
    const rlimit cpu{soft, soft + 5};
    setrlimit(RLIMIT_CPU, &cpu);
  }
  if (job.memory_bytes > 0) {
    // RLIMIT_DATA counts private writable mappings (heap, mmap'ed arrays, thread stacks), not
    // the shared libraries' code, so it bounds what this job allocates.
    const rlim_t bytes = MappedDataBytes() + job.memory_bytes;
    const rlimit data{bytes, bytes};
    setrlimit(RLIMIT_DATA, &data);
  }
}

strata::Expected<strata::server::MapBuildJob> BuildJobOf(const WorkerJob& job) {
  strata::server::MapBuildJob build;
  build.config = job.config;
  build.saved_model = job.saved_model;
  build.limits = job.limits;
  build.keep_cloud = job.keep_cloud;
  if (job.kind == WorkerJob::Source::kScene) {
    strata::Expected<strata::SceneSource> scene = strata::ParseSceneSource(job.source);
    if (!scene) return scene.error();
    build.source = std::move(scene).value();
  } else if (job.kind == WorkerJob::Source::kEdit) {
    // The version's files the server opened, inherited; the edits in the job's directory.
    std::ifstream file(job.source, std::ios::binary);
    const std::string text{std::istreambuf_iterator<char>(file), {}};
    strata::Expected<std::vector<strata::MapEdit>> edits = strata::server::ParseEdits(text);
    if (!edits) return edits.error();
    strata::server::VersionFiles files;
    if (job.tiled) {
      const std::filesystem::path list_path = job.out_dir / strata::server::kWorkerTilesFile;
      std::ifstream list_file(list_path, std::ios::binary);
      const std::string list_text{std::istreambuf_iterator<char>(list_file), {}};
      strata::server::Result<strata::server::TerrainTiles> list =
          strata::server::TerrainTiles::Parse(list_text, list_path);
      if (!list) return strata::Error{strata::ErrorCode::kInvalidInput, list.error().message};
      files.tiles =
          strata::server::OpenedTiles{std::make_shared<const strata::server::OpenedMapFile>(
                                          strata::server::kWorkerSourceFd, std::filesystem::path()),
                                      std::move(list).value()};
    } else {
      files.cloud = std::make_shared<const strata::server::OpenedMapFile>(
          strata::server::kWorkerSourceFd, std::filesystem::path());
      files.model = std::make_shared<const strata::server::OpenedMapFile>(
          strata::server::kWorkerBaseModelFd, std::filesystem::path());
    }
    build.source = strata::server::EditSource{std::move(files), std::move(edits).value()};
  } else if (job.kind == WorkerJob::Source::kFile) {
    // The file the server opened and checked, inherited on kWorkerSourceFd.
    build.source =
        strata::server::FileMapSource{std::make_shared<const strata::server::OpenedMapFile>(
                                          strata::server::kWorkerSourceFd, std::filesystem::path()),
                                      job.source};
  } else {
    // Uploaded points, which the server wrote in the job's directory.
    const int fd = open(job.source.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
      return strata::Error{
          strata::ErrorCode::kMapLoadFailed,
          "cannot open the uploaded points at " + job.source + ": " + std::strerror(errno)};
    }
    build.source = strata::server::FileMapSource{
        std::make_shared<const strata::server::OpenedMapFile>(fd, job.source), job.source};
  }
  return build;
}

int Run(const WorkerJob& job) {
  strata::Expected<strata::server::MapBuildJob> build = BuildJobOf(job);
  if (!build) {
    SendFailure(build.error());
    return strata::server::kWorkerExitFailed;
  }
  strata::server::BuildMonitor monitor;
  monitor.on_loaded = [](std::size_t raw, std::size_t dropped, double load_s) {
    WorkerReport report;
    report.kind = WorkerReport::Kind::kLoaded;
    report.raw_points = raw;
    report.dropped_nonfinite = dropped;
    report.load_s = load_s;
    Send(report);
  };
  // The assessment reports from its threads, often: a line per step and per percent is enough.
  std::mutex progress_mutex;
  WorkerReport last;
  last.kind = WorkerReport::Kind::kProgress;
  last.fraction = -1;
  monitor.on_progress = [&](strata::AssessmentStage step, double fraction) {
    std::lock_guard lock(progress_mutex);
    if (step == last.step && fraction < last.fraction + 0.01 && fraction < 1) return;
    last.step = step;
    last.fraction = fraction;
    Send(last);
  };
  strata::Expected<strata::server::BuiltMap> built =
      strata::server::BuildMapHere(std::move(build).value(), monitor);
  if (!built) {
    SendFailure(built.error());
    return strata::server::kWorkerExitFailed;
  }
  // An edit of a tiled version hands back the tiles it changed; anything else, its whole
  // model (and cloud).
  if (built->cut) {
    if (strata::Status written = strata::server::WriteCutTerrain(
            *built->cut, job.out_dir / strata::server::kWorkerCutDir);
        !written) {
      SendFailure(written.error());
      return strata::server::kWorkerExitFailed;
    }
  } else {
    if (strata::Status saved = strata::SaveModel(
            *built->model, (job.out_dir / strata::server::kWorkerModelFile).string());
        !saved) {
      SendFailure(saved.error());
      return strata::server::kWorkerExitFailed;
    }
    if (job.keep_cloud) {
      if (strata::Status saved = strata::SavePcd(
              built->cloud, (job.out_dir / strata::server::kWorkerCloudFile).string());
          !saved) {
        SendFailure(saved.error());
        return strata::server::kWorkerExitFailed;
      }
    }
  }
  WorkerReport done;
  done.version = built->version;
  done.edit = built->edit;
  Send(done);
  return strata::server::kWorkerExitDone;
}

}  // namespace

int main(int argc, char** argv) {
  // Dies with the server: a worker left behind would assess for nobody.
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  const strata::Expected<WorkerJob> job = strata::server::ParseWorkerArguments(argc, argv);
  if (!job) {
    std::fprintf(stderr, "strata-map-worker: %s\n", job.error().message.c_str());
    return strata::server::kWorkerExitUsage;
  }
  LimitSelf(*job);
  std::set_new_handler(OutOfMemory);
  std::set_terminate(OnTerminate);
  try {
    return Run(*job);
  } catch (const std::exception& e) {
    SendFailure({strata::ErrorCode::kMapLoadFailed,
                 std::string("making the map failed unexpectedly: ") + e.what()});
    return strata::server::kWorkerExitFailed;
  }
}
