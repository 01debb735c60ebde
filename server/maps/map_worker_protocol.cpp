#include "maps/map_worker_protocol.hpp"

#include <charconv>
#include <cmath>
#include <concepts>
#include <map>
#include <memory>
#include <set>
#include <type_traits>
#include <utility>

#include <Eigen/Core>

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include "common/packed_points.hpp"
#include "maps/store_files.hpp"

namespace strata::server {
namespace {

// Numbers in their shortest form that reads back exactly (std::to_chars).
template <typename Number>
std::string NumberText(Number value) {
  if constexpr (std::same_as<Number, bool>) {
    return value ? "true" : "false";
  } else {
    char digits[32];
    const auto [end, ec] = std::to_chars(digits, digits + sizeof digits, value);
    return {digits, ec == std::errc() ? end : digits};
  }
}

template <typename Number>
bool ParseNumber(std::string_view text, Number* value) {
  if constexpr (std::same_as<Number, bool>) {
    if (text != "true" && text != "false") return false;
    *value = text == "true";
    return true;
  } else {
    const char* end = text.data() + text.size();
    const auto [used, ec] = std::from_chars(text.data(), end, *value);
    return !text.empty() && ec == std::errc() && used == end;
  }
}

}  // namespace

std::vector<std::string> WorkerArguments(const WorkerJob& job) {
  std::vector<std::string> args = {"--out", job.out_dir.string()};
  switch (job.kind) {
    // One argument with '=': a client's file name may begin with '-'.
    case WorkerJob::Source::kFile: args.push_back("--file=" + job.source); break;
    case WorkerJob::Source::kScene: args.push_back("--scene=" + job.source); break;
    case WorkerJob::Source::kPoints: args.push_back("--points=" + job.source); break;
    case WorkerJob::Source::kEdit: args.push_back("--edit=" + job.source); break;
  }
  if (job.saved_model) args.emplace_back("--saved-model");
  if (job.keep_cloud) args.emplace_back("--keep-cloud");
  if (job.tiled) args.emplace_back("--tiled");
  args.insert(args.end(), {"--max-points", NumberText(job.limits.max_points), "--max-file-bytes",
                           NumberText(job.limits.max_file_bytes), "--max-abs-coordinate-m",
                           NumberText(job.limits.max_abs_coordinate_m), "--memory-bytes",
                           NumberText(job.memory_bytes), "--cpu-s", NumberText(job.cpu_s)});
  ForEachField(job.config, [&args](std::string_view name, const auto& value) {
    args.emplace_back("--config");
    args.push_back(std::string(name) + "=" + NumberText(value));
  });
  return args;
}

Expected<WorkerJob> ParseWorkerArguments(int argc, const char* const* argv) {
  WorkerJob job;
  std::string out, file, scene, points, edit;
  std::vector<std::string> config;
  CLI::App app("strata-map-worker: makes one map for strata-server (not for people)");
  app.add_option("--out", out)->required();
  CLI::Option_group* source = app.add_option_group("source");
  source->add_option("--file", file);
  source->add_option("--scene", scene);
  source->add_option("--points", points);
  source->add_option("--edit", edit);
  source->require_option(1);
  app.add_flag("--saved-model", job.saved_model);
  app.add_flag("--keep-cloud", job.keep_cloud);
  app.add_flag("--tiled", job.tiled);
  app.add_option("--max-points", job.limits.max_points)->required();
  app.add_option("--max-file-bytes", job.limits.max_file_bytes)->required();
  app.add_option("--max-abs-coordinate-m", job.limits.max_abs_coordinate_m)->required();
  app.add_option("--memory-bytes", job.memory_bytes)->required();
  app.add_option("--cpu-s", job.cpu_s)->required();
  app.add_option("--config", config)->required();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return Error{ErrorCode::kInvalidInput, std::string("bad worker arguments: ") + e.what()};
  }
  job.out_dir = out;
  if (!file.empty()) {
    job.kind = WorkerJob::Source::kFile;
    job.source = file;
  } else if (!scene.empty()) {
    job.kind = WorkerJob::Source::kScene;
    job.source = scene;
  } else if (!points.empty()) {
    job.kind = WorkerJob::Source::kPoints;
    job.source = points;
  } else {
    job.kind = WorkerJob::Source::kEdit;
    job.source = edit;
  }
  // Every field exactly once: a field the caller forgot must not silently take its default.
  std::map<std::string, std::string, std::less<>> given;
  for (const std::string& entry : config) {
    const std::size_t eq = entry.find('=');
    if (eq == std::string::npos ||
        !given.emplace(entry.substr(0, eq), entry.substr(eq + 1)).second) {
      return Error{ErrorCode::kInvalidInput, "bad worker argument --config " + entry};
    }
  }
  std::string problem;
  ForEachField(job.config, [&](std::string_view name, auto& value) {
    const auto it = given.find(name);
    if (it == given.end()) {
      problem = "--config " + std::string(name) + " is missing";
    } else if (!ParseNumber(it->second, &value)) {
      problem = "--config " + std::string(name) + "=" + it->second + " is not a number";
    } else {
      given.erase(it);
    }
  });
  if (problem.empty() && !given.empty()) problem = "unknown --config " + given.begin()->first;
  if (!problem.empty()) return Error{ErrorCode::kInvalidInput, "bad worker arguments: " + problem};
  return job;
}

namespace {

constexpr std::string_view kAddObstacle = "add_obstacle";
constexpr std::string_view kRemovePoints = "remove_points";
constexpr std::string_view kScan = "scan";

std::string_view KindWord(MapEdit::Kind kind) {
  switch (kind) {
    case MapEdit::Kind::kAddObstacle: return kAddObstacle;
    case MapEdit::Kind::kRemovePoints: return kRemovePoints;
    case MapEdit::Kind::kScan: return kScan;
  }
  return "unknown";
}

}  // namespace

std::string FormatEdits(std::span<const MapEdit> edits) {
  std::string text;
  for (const MapEdit& edit : edits) {
    const bool scan = edit.kind == MapEdit::Kind::kScan;
    const std::size_t points = scan && edit.points != nullptr ? edit.points->size() : 0;
    text += KindWord(edit.kind);
    if (scan) text += " " + NumberText(points);
    text += " " + NumberText(edit.region.z_min_m) + " " + NumberText(edit.region.z_max_m);
    for (const Eigen::Vector2d& corner : edit.region.polygon_m) {
      text += " " + NumberText(corner.x()) + " " + NumberText(corner.y());
    }
    text += '\n';
    if (points > 0) {
      text.reserve(text.size() + points * kPackedPointBytes);
      for (const Eigen::Vector3f& p : *edit.points) AppendPackedPoint(p, &text);
    }
  }
  return text;
}

Expected<std::vector<MapEdit>> ParseEdits(std::string_view contents) {
  std::string_view text = contents;
  std::vector<MapEdit> edits;
  int line_number = 0;
  while (!text.empty()) {
    ++line_number;
    const std::size_t end = text.find('\n');
    const std::string_view line = text.substr(0, end);
    text = end == std::string_view::npos ? std::string_view() : text.substr(end + 1);
    std::vector<std::string_view> words;
    for (std::size_t at = 0; at < line.size();) {
      const std::size_t space = std::min(line.find(' ', at), line.size());
      words.push_back(line.substr(at, space - at));
      at = space + 1;
    }
    MapEdit edit;
    // A scan's point count comes after its kind; the region's words follow in every kind.
    const bool scan = !words.empty() && words[0] == kScan;
    const std::size_t first = scan ? 2 : 1;
    std::size_t points = 0;
    bool good = words.size() >= first + 2 && (words.size() - first) % 2 == 0 &&
                (scan || words[0] == kAddObstacle || words[0] == kRemovePoints) &&
                (!scan || ParseNumber(words[1], &points)) &&
                ParseNumber(words[first], &edit.region.z_min_m) &&
                ParseNumber(words[first + 1], &edit.region.z_max_m);
    edit.kind = scan                                        ? MapEdit::Kind::kScan
                : words.empty() || words[0] == kAddObstacle ? MapEdit::Kind::kAddObstacle
                                                            : MapEdit::Kind::kRemovePoints;
    for (std::size_t i = first + 2; good && i + 1 < words.size(); i += 2) {
      Eigen::Vector2d corner;
      good = ParseNumber(words[i], &corner.x()) && ParseNumber(words[i + 1], &corner.y());
      edit.region.polygon_m.push_back(corner);
    }
    if (!good) {
      return Error{ErrorCode::kInvalidInput,
                   fmt::format("bad edits file: line {} is not KIND Z_MIN Z_MAX X Y ... (KIND "
                               "add_obstacle or remove_points) or scan POINTS Z_MIN Z_MAX X Y ...",
                               line_number)};
    }
    if (points > 0) {
      // The scan's points follow its line, packed.
      if (points > text.size() / kPackedPointBytes) {
        return Error{ErrorCode::kInvalidInput,
                     fmt::format("bad edits file: the scan of line {} has {} points, but only {} "
                                 "bytes follow it",
                                 line_number, points, text.size())};
      }
      auto cloud = std::make_shared<PointCloud>();
      cloud->reserve(points);
      for (std::size_t i = 0; i < points; ++i) {
        cloud->push_back(ReadPackedPoint(text.data() + i * kPackedPointBytes));
      }
      text.remove_prefix(points * kPackedPointBytes);
      edit.points = std::move(cloud);
    }
    edits.push_back(std::move(edit));
  }
  return edits;
}

std::string FormatWorkerReport(const WorkerReport& report) {
  switch (report.kind) {
    case WorkerReport::Kind::kLoaded:
      return "loaded " + NumberText(report.raw_points) + " " +
             NumberText(report.dropped_nonfinite) + " " + NumberText(report.load_s) + "\n";
    case WorkerReport::Kind::kProgress:
      return std::string("progress ") + AssessmentStageName(report.step) + " " +
             NumberText(report.fraction) + "\n";
    case WorkerReport::Kind::kFailed: {
      // One line: the message's own line breaks become spaces.
      std::string message = report.error.message;
      for (char& c : message) {
        if (c == '\n' || c == '\r') c = ' ';
      }
      return std::string("failed ") + ErrorCodeName(report.error.code) + " " +
             (report.error.field.empty() ? "-" : report.error.field) + " " + message + "\n";
    }
    case WorkerReport::Kind::kDone: {
      if (!report.edit) return "done " + report.version + "\n";
      // The reason last: it is a sentence (one line).
      const EditFigures& edit = *report.edit;
      std::string reason = edit.full_reason;
      for (char& c : reason) {
        if (c == '\n' || c == '\r') c = ' ';
      }
      return "done " + report.version + " edit " + NumberText(edit.apply_s) + " " +
             NumberText(edit.reassess_s) + " " + NumberText(edit.reassessed_columns) + " " +
             NumberText(edit.scan_points_outside_region) + " " +
             NumberText(edit.scan_points_thinned) + " " + NumberText(edit.full_reassessment) + " " +
             NumberText(edit.changed_columns.min.x()) + " " +
             NumberText(edit.changed_columns.min.y()) + " " +
             NumberText(edit.changed_columns.max.x()) + " " +
             NumberText(edit.changed_columns.max.y()) + " " + NumberText(edit.cloud_points) + " " +
             NumberText(edit.from_tiles) + " " + reason + "\n";
    }
  }
  return "\n";
}

std::optional<WorkerReport> ParseWorkerReport(std::string_view line) {
  // The first `count` words, and the rest of the line after them.
  const auto split = [line](std::size_t count) {
    std::vector<std::string_view> words;
    std::size_t at = 0;
    while (words.size() < count && at <= line.size()) {
      const std::size_t space = line.find(' ', at);
      words.push_back(line.substr(at, space - at));
      at = space == std::string_view::npos ? line.size() + 1 : space + 1;
    }
    return std::pair(words, at <= line.size() ? line.substr(at) : std::string_view());
  };
  WorkerReport report;
  if (line.starts_with("done ")) {
    const auto [done, reason] = split(15);
    if (done.size() == 2 && !done[1].empty() && reason.empty()) {
      report.version = std::string(done[1]);
      return report;
    }
    EditFigures edit;
    Eigen::Vector3i& min = edit.changed_columns.min;
    Eigen::Vector3i& max = edit.changed_columns.max;
    max.z() = 0;
    if (done.size() == 15 && !done[1].empty() && done[2] == "edit" &&
        ParseNumber(done[3], &edit.apply_s) && ParseNumber(done[4], &edit.reassess_s) &&
        ParseNumber(done[5], &edit.reassessed_columns) &&
        ParseNumber(done[6], &edit.scan_points_outside_region) &&
        ParseNumber(done[7], &edit.scan_points_thinned) &&
        ParseNumber(done[8], &edit.full_reassessment) && ParseNumber(done[9], &min.x()) &&
        ParseNumber(done[10], &min.y()) && ParseNumber(done[11], &max.x()) &&
        ParseNumber(done[12], &max.y()) && ParseNumber(done[13], &edit.cloud_points) &&
        ParseNumber(done[14], &edit.from_tiles)) {
      edit.full_reason = std::string(reason);
      report.version = std::string(done[1]);
      report.edit = std::move(edit);
      return report;
    }
    return std::nullopt;
  }
  const auto [words, rest] = split(line.starts_with("failed ") ? 3 : 4);
  if (words[0] == "loaded" && words.size() == 4 && rest.empty()) {
    report.kind = WorkerReport::Kind::kLoaded;
    if (ParseNumber(words[1], &report.raw_points) &&
        ParseNumber(words[2], &report.dropped_nonfinite) && ParseNumber(words[3], &report.load_s)) {
      return report;
    }
  } else if (words[0] == "progress" && words.size() == 3 && rest.empty()) {
    report.kind = WorkerReport::Kind::kProgress;
    for (int step = 0; step <= static_cast<int>(AssessmentStage::kFields); ++step) {
      if (words[1] == AssessmentStageName(static_cast<AssessmentStage>(step))) {
        report.step = static_cast<AssessmentStage>(step);
        if (ParseNumber(words[2], &report.fraction) && report.fraction >= 0 &&
            report.fraction <= 1) {
          return report;
        }
      }
    }
  } else if (words[0] == "failed" && words.size() == 3) {
    report.kind = WorkerReport::Kind::kFailed;
    if (const std::optional<ErrorCode> code = ErrorCodeFromName(words[1])) {
      report.error = Error{*code, std::string(rest), words[2] == "-" ? "" : std::string(words[2])};
      return report;
    }
  }
  return std::nullopt;
}

Status WriteCutTerrain(const CutTerrain& cut, const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec)
    return Error{ErrorCode::kMapLoadFailed, "cannot create " + dir.string() + ": " + ec.message()};
  const auto write = [&](const std::string& name, std::string_view bytes) -> Status {
    if (ServiceStatus written = store_files::WriteNewFile(dir / name, bytes, /*durable=*/false);
        !written) {
      return Error{ErrorCode::kMapLoadFailed, written.error().message};
    }
    return Status::Ok();
  };
  if (Status written = write(kWorkerTilesFile, cut.list.Format()); !written) return written;
  for (const auto& [name, bytes] : cut.tiles) {
    if (Status written = write(name, bytes); !written) return written;
  }
  return Status::Ok();
}

Expected<CutTerrain> ReadCutTerrain(const std::filesystem::path& dir) {
  const auto failed = [](const std::string& why) {
    return Error{ErrorCode::kMapLoadFailed, "the map worker's tiles: " + why};
  };
  Result<std::optional<std::string>> list_text =
      store_files::ReadFileIfExists(dir / kWorkerTilesFile);
  if (!list_text) return failed(list_text.error().message);
  if (!list_text->has_value()) return failed("no list of tiles in " + dir.string());
  Result<TerrainTiles> list = TerrainTiles::Parse(**list_text, dir / kWorkerTilesFile);
  if (!list) return failed(list.error().message);
  CutTerrain cut;
  cut.list = std::move(list).value();
  std::set<std::string> read;
  for (const std::string& name : cut.list.Names()) {
    if (!read.insert(name).second) continue;
    Result<std::optional<std::string>> bytes = store_files::ReadFileIfExists(dir / name);
    if (!bytes) return failed(bytes.error().message);
    if (!bytes->has_value()) continue;  // The base's.
    if (TileName(**bytes) != name) return failed("tile " + name + " does not hold its bytes");
    cut.tiles.emplace_back(name, std::move(**bytes));
  }
  return cut;
}

}  // namespace strata::server
