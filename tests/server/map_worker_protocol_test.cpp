// The worker's command line and report lines read back as what was written, and anything
// else is refused (map_worker_protocol.hpp).
#include "maps/map_worker_protocol.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "common/packed_points.hpp"

namespace strata::server {
namespace {

using ::testing::HasSubstr;

Expected<WorkerJob> Parse(const std::vector<std::string>& args) {
  std::vector<const char*> argv = {"strata-map-worker"};
  for (const std::string& arg : args) argv.push_back(arg.c_str());
  return ParseWorkerArguments(static_cast<int>(argv.size()), argv.data());
}

// A job whose every field differs from its default, numbers that are not short decimals
// included, so that a field dropped or rounded on the way shows.
WorkerJob OddJob() {
  WorkerJob job;
  job.kind = WorkerJob::Source::kScene;
  job.source = "scene:outdoor_site:3:size_m=200";
  job.saved_model = true;
  job.keep_cloud = true;
  double value = 0.1;
  ForEachField(job.config, [&value](std::string_view, auto& field) {
    using Field = std::remove_reference_t<decltype(field)>;
    if constexpr (std::is_same_v<Field, bool>) {
      field = !field;
    } else if constexpr (std::is_floating_point_v<Field>) {
      field = value / 3;
      value += 0.1;
    } else {
      field = field + 7;
    }
  });
  job.limits.max_points = 123457;
  job.limits.max_file_bytes = 987654321;
  job.limits.max_abs_coordinate_m = 1.0 / 3;
  job.out_dir = "/tmp/a dir with spaces";
  job.memory_bytes = (std::uint64_t{5} << 30) + 1;
  job.cpu_s = 12.5;
  return job;
}

TEST(WorkerArguments, ReadBackAsTheSameJob) {
  const WorkerJob job = OddJob();
  Expected<WorkerJob> back = Parse(WorkerArguments(job));
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->kind, job.kind);
  EXPECT_EQ(back->source, job.source);
  EXPECT_EQ(back->saved_model, job.saved_model);
  EXPECT_EQ(back->keep_cloud, job.keep_cloud);
  EXPECT_FALSE(FirstDifference(back->config, job.config).has_value());
  EXPECT_EQ(back->config.num_threads, job.config.num_threads);
  EXPECT_EQ(back->limits.max_points, job.limits.max_points);
  EXPECT_EQ(back->limits.max_file_bytes, job.limits.max_file_bytes);
  EXPECT_EQ(back->limits.max_abs_coordinate_m, job.limits.max_abs_coordinate_m);
  EXPECT_EQ(back->out_dir, job.out_dir);
  EXPECT_EQ(back->memory_bytes, job.memory_bytes);
  EXPECT_EQ(back->cpu_s, job.cpu_s);

  // A kFile source is the client's own name for the file, which may begin with '-'.
  for (const auto kind : {WorkerJob::Source::kFile, WorkerJob::Source::kPoints}) {
    for (const char* source : {"/maps/a b.pcd", "-x.pcd", "--keep-cloud"}) {
      WorkerJob other = job;
      other.kind = kind;
      other.source = source;
      Expected<WorkerJob> parsed = Parse(WorkerArguments(other));
      ASSERT_TRUE(parsed.ok()) << source << ": " << parsed.error().message;
      EXPECT_EQ(parsed->kind, kind);
      EXPECT_EQ(parsed->source, other.source);
      EXPECT_EQ(parsed->keep_cloud, other.keep_cloud);
    }
  }
}

TEST(WorkerArguments, EveryConfigFieldMustBeGivenOnce) {
  const std::vector<std::string> args = WorkerArguments(OddJob());
  // Without the last --config: that field is missing, not silently defaulted.
  std::vector<std::string> missing = args;
  missing.resize(missing.size() - 2);
  Expected<WorkerJob> parsed = Parse(missing);
  ASSERT_FALSE(parsed.ok());
  EXPECT_THAT(parsed.error().message, HasSubstr("num_threads is missing"));

  std::vector<std::string> unknown = args;
  unknown.insert(unknown.end(), {"--config", "grid.colour=3"});
  parsed = Parse(unknown);
  ASSERT_FALSE(parsed.ok());
  EXPECT_THAT(parsed.error().message, HasSubstr("grid.colour"));

  std::vector<std::string> twice = args;
  twice.insert(twice.end(), {"--config", "num_threads=1"});
  EXPECT_FALSE(Parse(twice).ok());

  std::vector<std::string> not_a_number = args;
  not_a_number.back() = "num_threads=many";
  parsed = Parse(not_a_number);
  ASSERT_FALSE(parsed.ok());
  EXPECT_THAT(parsed.error().message, HasSubstr("num_threads=many"));
}

TEST(WorkerArguments, OneSourceExactly) {
  std::vector<std::string> args = WorkerArguments(OddJob());
  std::vector<std::string> two = args;
  two.emplace_back("--file=/maps/x.pcd");
  EXPECT_FALSE(Parse(two).ok());
  std::vector<std::string> none;
  std::copy_if(args.begin(), args.end(), std::back_inserter(none),
               [](const std::string& arg) { return !arg.starts_with("--scene="); });
  ASSERT_EQ(none.size() + 1, args.size());
  EXPECT_FALSE(Parse(none).ok());
}

TEST(WorkerReport, LinesReadBackAsTheirReports) {
  WorkerReport loaded;
  loaded.kind = WorkerReport::Kind::kLoaded;
  loaded.raw_points = 50'000'001;
  loaded.dropped_nonfinite = 17;
  loaded.load_s = 0.1 + 0.2;
  WorkerReport progress;
  progress.kind = WorkerReport::Kind::kProgress;
  progress.step = AssessmentStage::kSurfaces;
  progress.fraction = 1.0 / 3;
  WorkerReport failed;
  failed.kind = WorkerReport::Kind::kFailed;
  failed.error = Error{ErrorCode::kResourceExhausted, "too many points: 51000000 > 50000000",
                       "grid.max_columns"};
  WorkerReport done;
  done.version = "57b2470b769fbc7020073d736f8b88cc";
  WorkerReport edited = done;
  edited.edit = EditFigures{0.25, 1.0 / 3, true,     "the edited cloud's bounds change the grid",
                            4242, 123'456, 7'890'123};
  edited.edit->changed_columns = {{12, 345, 0}, {678, 4001, 0}};
  edited.edit->cloud_points = 208'000'123;
  edited.edit->from_tiles = true;
  for (const WorkerReport& report : {loaded, progress, failed, done, edited}) {
    const std::string line = FormatWorkerReport(report);
    ASSERT_FALSE(line.empty());
    ASSERT_EQ(line.back(), '\n');
    const std::optional<WorkerReport> back =
        ParseWorkerReport(std::string_view(line).substr(0, line.size() - 1));
    ASSERT_TRUE(back.has_value()) << line;
    EXPECT_EQ(back->kind, report.kind) << line;
    EXPECT_EQ(back->raw_points, report.raw_points) << line;
    EXPECT_EQ(back->dropped_nonfinite, report.dropped_nonfinite) << line;
    EXPECT_EQ(back->load_s, report.load_s) << line;
    EXPECT_EQ(back->step, report.step) << line;
    EXPECT_EQ(back->fraction, report.fraction) << line;
    EXPECT_EQ(back->error.code, report.error.code) << line;
    EXPECT_EQ(back->error.message, report.error.message) << line;
    EXPECT_EQ(back->error.field, report.error.field) << line;
    EXPECT_EQ(back->version, report.version) << line;
    ASSERT_EQ(back->edit.has_value(), report.edit.has_value()) << line;
    if (report.edit) {
      EXPECT_EQ(back->edit->apply_s, report.edit->apply_s) << line;
      EXPECT_EQ(back->edit->reassess_s, report.edit->reassess_s) << line;
      EXPECT_EQ(back->edit->full_reassessment, report.edit->full_reassessment) << line;
      EXPECT_EQ(back->edit->full_reason, report.edit->full_reason) << line;
      EXPECT_EQ(back->edit->reassessed_columns, report.edit->reassessed_columns) << line;
      EXPECT_EQ(back->edit->scan_points_outside_region, report.edit->scan_points_outside_region)
          << line;
      EXPECT_EQ(back->edit->scan_points_thinned, report.edit->scan_points_thinned) << line;
      EXPECT_EQ(back->edit->changed_columns.min, report.edit->changed_columns.min) << line;
      EXPECT_EQ(back->edit->changed_columns.max, report.edit->changed_columns.max) << line;
      EXPECT_EQ(back->edit->cloud_points, report.edit->cloud_points) << line;
      EXPECT_EQ(back->edit->from_tiles, report.edit->from_tiles) << line;
    }
  }
}

// A tiled edit's result travels as its list and the tiles it cut: read back as written, a
// tile not handed back is the base's, and a tile whose bytes are not its name's is refused.
TEST(WorkerCut, TheTilesReadBackAsWrittenAndADamagedOneIsRefused) {
  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) / ("worker_cut_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  CutTerrain cut;
  const std::string header = "header bytes", changed = "a changed tile", kept = "a kept tile";
  cut.list.header = TileName(header);
  cut.list.model = {TileName(kept), TileName(changed), TileName(changed)};
  cut.tiles = {{TileName(header), header}, {TileName(changed), changed}};
  ASSERT_TRUE(WriteCutTerrain(cut, dir).ok());
  const Expected<CutTerrain> back = ReadCutTerrain(dir);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->list.Format(), cut.list.Format());
  EXPECT_EQ(back->tiles, cut.tiles);

  std::ofstream(dir / TileName(changed), std::ios::binary | std::ios::trunc) << "damaged";
  const Expected<CutTerrain> damaged = ReadCutTerrain(dir);
  ASSERT_FALSE(damaged.ok());
  EXPECT_THAT(damaged.error().message, ::testing::HasSubstr(TileName(changed)));
  std::filesystem::remove(dir / kWorkerTilesFile);
  const Expected<CutTerrain> unlisted = ReadCutTerrain(dir);
  ASSERT_FALSE(unlisted.ok());
  EXPECT_THAT(unlisted.error().message, ::testing::HasSubstr("no list of tiles"));
  std::filesystem::remove_all(dir);
}

// An edit job's edits go to the worker as a file: every number reads back exactly, and a
// line that is not an edit is refused naming it.
TEST(WorkerEdits, EditsReadBackExactlyAndAnythingElseIsRefused) {
  MapEdit obstacle;
  obstacle.region.polygon_m = {{0.1, 0.2}, {1.0 / 3, 0.2}, {1.0 / 3, 2.0 / 3}};
  obstacle.region.z_min_m = -0.1;
  obstacle.region.z_max_m = 1e-3;
  MapEdit removal = obstacle;
  removal.kind = MapEdit::Kind::kRemovePoints;
  removal.region.polygon_m.push_back({-5e10, 7});
  const std::vector<MapEdit> edits = {obstacle, removal};
  const Expected<std::vector<MapEdit>> back = ParseEdits(FormatEdits(edits));
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->size(), 2u);
  for (std::size_t i = 0; i < edits.size(); ++i) {
    EXPECT_EQ((*back)[i].kind, edits[i].kind);
    EXPECT_EQ((*back)[i].region.polygon_m, edits[i].region.polygon_m);
    EXPECT_EQ((*back)[i].region.z_min_m, edits[i].region.z_min_m);
    EXPECT_EQ((*back)[i].region.z_max_m, edits[i].region.z_max_m);
  }
  EXPECT_TRUE(ParseEdits("").ok());
  for (const char* bad : {"add_obstacle 0 1 2\n", "grow 0 1 2 3\n", "add_obstacle 0 x 1 1\n", "\n",
                          "remove_points 0 1 1 1 2\n"}) {
    const Expected<std::vector<MapEdit>> refused = ParseEdits(bad);
    ASSERT_FALSE(refused.ok()) << bad;
    EXPECT_THAT(refused.error().message, HasSubstr("line 1")) << bad;
  }
}

// A scan's points go to the worker in binary after its line: every point reads back bit for
// bit (the extremes of float and a newline's bytes among them), the edits around it too, and
// a file that ends inside the points is refused naming the scan's line.
TEST(WorkerEdits, AScansPointsReadBackBitForBit) {
  MapEdit obstacle;
  obstacle.region.polygon_m = {{0.1, 0.2}, {1.0 / 3, 0.2}, {1.0 / 3, 2.0 / 3}};
  obstacle.region.z_min_m = -0.1;
  obstacle.region.z_max_m = 1e-3;
  MapEdit scan = obstacle;
  scan.kind = MapEdit::Kind::kScan;
  std::mt19937 random(43);
  std::uniform_real_distribution<float> coordinate(-1e4f, 1e4f);
  PointCloud points;
  for (int i = 0; i < 1000; ++i) points.emplace_back(coordinate(random), coordinate(random), 0.1f);
  points.emplace_back(std::numeric_limits<float>::denorm_min(), std::numeric_limits<float>::max(),
                      std::numeric_limits<float>::lowest());
  points.emplace_back(-0.0f, 1.0f / 3, std::bit_cast<float>(0x0A0A0A0Au));  // '\n' bytes.
  scan.points = std::make_shared<const PointCloud>(points);
  MapEdit empty_scan = scan;
  empty_scan.points = nullptr;
  MapEdit removal = obstacle;
  removal.kind = MapEdit::Kind::kRemovePoints;
  const std::vector<MapEdit> edits = {obstacle, scan, empty_scan, removal, scan};
  const std::string contents = FormatEdits(edits);
  const Expected<std::vector<MapEdit>> back = ParseEdits(contents);
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->size(), edits.size());
  for (std::size_t i = 0; i < edits.size(); ++i) {
    EXPECT_EQ((*back)[i].kind, edits[i].kind) << i;
    EXPECT_EQ((*back)[i].region.polygon_m, edits[i].region.polygon_m) << i;
    EXPECT_EQ((*back)[i].region.z_min_m, edits[i].region.z_min_m) << i;
    EXPECT_EQ((*back)[i].region.z_max_m, edits[i].region.z_max_m) << i;
    const std::size_t count = edits[i].points == nullptr ? 0 : edits[i].points->size();
    ASSERT_EQ((*back)[i].points == nullptr ? 0 : (*back)[i].points->size(), count) << i;
    if (count == 0) continue;
    EXPECT_EQ(std::memcmp((*back)[i].points->data(), points.data(), count * sizeof(points[0])), 0)
        << i;
  }
  // 12 bytes a point, little-endian.
  const std::size_t line = contents.find('\n', contents.find("scan")) + 1;
  EXPECT_EQ(contents.substr(0, line).find("scan 1002 "), contents.find("scan"));
  EXPECT_EQ(ReadLittleEndianFloat(contents.data() + line + 4), points[0].y());

  const std::string cut = FormatEdits(std::vector<MapEdit>{obstacle, scan});
  const Expected<std::vector<MapEdit>> refused = ParseEdits(cut.substr(0, cut.size() - 1));
  ASSERT_FALSE(refused.ok());
  EXPECT_THAT(refused.error().message, HasSubstr("line 2"));
  for (const char* bad : {"scan 0 1 2 3 4 5\n", "scan x 0 1 2 3 4 5 6 7\n", "scan\n"}) {
    const Expected<std::vector<MapEdit>> wrong = ParseEdits(bad);
    ASSERT_FALSE(wrong.ok()) << bad;
    EXPECT_THAT(wrong.error().message, HasSubstr("line 1")) << bad;
  }
}

TEST(WorkerReport, AMessageStaysOnOneLineAndAnEmptyFieldReadsBackEmpty) {
  WorkerReport failed;
  failed.kind = WorkerReport::Kind::kFailed;
  failed.error = Error{ErrorCode::kMapLoadFailed, "line one\nline two", ""};
  const std::string line = FormatWorkerReport(failed);
  EXPECT_EQ(line.find('\n'), line.size() - 1);
  const std::optional<WorkerReport> back = ParseWorkerReport(line.substr(0, line.size() - 1));
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->error.message, "line one line two");
  EXPECT_EQ(back->error.field, "");
}

TEST(WorkerReport, AnythingElseIsNotAReport) {
  for (const char* line :
       {"", "done", "done a b", "loaded 1 2", "loaded 1 2 3 4", "loaded -1 2 3", "loaded x 2 3",
        "progress fields", "progress fields 1.5", "progress polishing 0.5", "failed NOPE - x",
        "failed MAP_LOAD_FAILED", "PCL warning: something", "Loaded 1 2 3"}) {
    EXPECT_FALSE(ParseWorkerReport(line).has_value()) << "'" << line << "'";
  }
}

}  // namespace
}  // namespace strata::server
