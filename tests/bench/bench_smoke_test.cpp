// Smoke test of strata-bench: the real binary on a small built-in scene
// with 3 pairs and all three methods. It proves the harness works — rows, files and sane
// values — not how well any method plans (that is docs/benchmarks.md's job).

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_util/run_command.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

// Runs strata-bench with `args` (as on a shell's command line); returns the exit code and
// appends stdout, then stderr, to *output.
int RunBench(const std::string& args, std::string* output) {
  std::vector<std::string> argv = test_util::ShellWords(args);
  argv.insert(argv.begin(), STRATA_BENCH_BIN);
  const test_util::CommandResult run = test_util::RunCommand(argv);
  *output += run.out + run.err;
  return run.exit_code;
}

// A CSV file as header → column index and rows of fields (no quoted commas in the columns
// read here; the message column is last and skipped).
struct Csv {
  std::map<std::string, std::size_t> column;
  std::vector<std::vector<std::string>> rows;
  const std::string& At(std::size_t row, const std::string& name) const {
    return rows[row].at(column.at(name));
  }
  double Number(std::size_t row, const std::string& name) const { return std::stod(At(row, name)); }
};

Csv ReadCsv(const std::filesystem::path& path) {
  Csv csv;
  std::ifstream file(path);
  std::string line;
  for (bool header = true; std::getline(file, line); header = false) {
    std::vector<std::string> fields;
    std::stringstream in(line);
    for (std::string field; std::getline(in, field, ',');) fields.push_back(field);
    if (header) {
      for (std::size_t i = 0; i < fields.size(); ++i) csv.column[fields[i]] = i;
    } else {
      csv.rows.push_back(fields);
    }
  }
  return csv;
}

class BenchSmokeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("strata_bench_smoke_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path dir_;
};

TEST_F(BenchSmokeTest, ThreeMethodsOnThreePairsWriteSaneRows) {
  std::string output;
  const int code = RunBench(
      "--scene stairs_ramp_room --pairs 3 --seed 1 --threads 1 "
      "--time-limit 1 --methods strata,liu,krusi --out '" +
          dir_.string() + "'",
      &output);
  ASSERT_EQ(code, 0) << output;
  EXPECT_THAT(output, HasSubstr("| strata |"));
  EXPECT_THAT(output, HasSubstr("| liu |"));
  EXPECT_THAT(output, HasSubstr("| krusi |"));

  const Csv results = ReadCsv(dir_ / "results.csv");
  ASSERT_EQ(results.rows.size(), 9u) << "one row per method × query";
  std::map<std::string, std::set<int>> queries_of;
  std::map<std::string, int> successes;
  const std::vector<std::string> checks = {"check_ground",   "check_clearance",
                                           "check_headroom", "check_body_height",
                                           "check_speed",    "check_acceleration"};
  for (std::size_t r = 0; r < results.rows.size(); ++r) {
    const std::string method = results.At(r, "method");
    queries_of[method].insert(std::stoi(results.At(r, "query")));
    const double plan_s = results.Number(r, "plan_s");
    EXPECT_TRUE(std::isfinite(plan_s) && plan_s >= 0 && plan_s < 30) << "row " << r;
    const bool success = results.At(r, "success") == "1";
    EXPECT_EQ(success, results.At(r, "reason") == "OK") << "row " << r;
    if (method == "strata" && success) {
      // A returned trajectory passes Plan's verifier again, and the harness's own check.
      EXPECT_EQ(results.At(r, "verify_violations"), "0") << "row " << r;
      for (const std::string& check : checks) EXPECT_EQ(results.At(r, check), "0") << check;
    } else {
      // Baselines' paths and failed plans are not checked.
      EXPECT_EQ(results.At(r, "verify_violations"), "-1") << "row " << r;
      for (const std::string& check : checks) EXPECT_EQ(results.At(r, check), "-1") << check;
    }
    if (method == "strata" && !success) {
      // Strata's only way to fail on a reachable pair: a trajectory verification kept refusing.
      EXPECT_EQ(results.At(r, "reason"), "OPTIMIZATION_FAILED") << "row " << r;
    }
    if (!success) continue;
    ++successes[method];
    // A path is at least as long as the straight line between its (snapped) ends.
    const double straight = std::hypot(results.Number(r, "goal_x") - results.Number(r, "start_x"),
                                       results.Number(r, "goal_y") - results.Number(r, "start_y"),
                                       results.Number(r, "goal_z") - results.Number(r, "start_z"));
    const double snaps = results.Number(r, "start_snap_m") + results.Number(r, "goal_snap_m");
    EXPECT_GE(results.Number(r, "length_m"), straight - snaps - 1e-6) << "row " << r;
    EXPECT_LT(results.Number(r, "length_m"), 10 * straight + 50) << "row " << r;
    for (const char* kappa : {"kappa_m", "kappa_xy_m"}) {
      const double k = results.Number(r, kappa);
      EXPECT_TRUE(std::isfinite(k) && k >= 0 && k < 1e3) << kappa << " in row " << r;
    }
    EXPECT_GE(std::stoi(results.At(r, "path_points")), 2) << "row " << r;
  }
  // What this run achieves on this small room (stairs, a ramp, open floor): Liu-style's graph
  // search solves every pair; Strata all but one at most (a start in a room corner can keep
  // its acceleration 1-2% over the bound through all three attempts, as the third pair does).
  // Krüsi-style samples against a 1 s limit, so its count depends on the machine: not asserted.
  EXPECT_EQ(successes["liu"], 3);
  EXPECT_GE(successes["strata"], 2);
  EXPECT_THAT(output, HasSubstr("independent check of " + std::to_string(successes["strata"]) +
                                " checked: ground 0, clearance 0, headroom 0, body height 0, "
                                "speed 0, acceleration 0"));
  for (const char* method : {"strata", "liu", "krusi"}) {
    EXPECT_EQ(queries_of[method], (std::set<int>{0, 1, 2})) << method;
  }

  const Csv summary = ReadCsv(dir_ / "summary.csv");
  ASSERT_EQ(summary.rows.size(), 3u);
  for (std::size_t r = 0; r < summary.rows.size(); ++r) {
    EXPECT_EQ(summary.At(r, "queries"), "3");
    const double t_a = summary.Number(r, "t_a_s");
    EXPECT_TRUE(std::isfinite(t_a) && t_a > 0 && t_a < 60) << summary.At(r, "method");
  }

  // The plot inputs exist and say what was run.
  EXPECT_GT(ReadCsv(dir_ / "cloud.csv").rows.size(), 1000u);
  EXPECT_EQ(ReadCsv(dir_ / "paths.csv").column.count("method"), 1u);
  std::ifstream meta_file(dir_ / "meta.json");
  const nlohmann::json meta = nlohmann::json::parse(meta_file, nullptr, false);
  ASSERT_FALSE(meta.is_discarded());
  EXPECT_EQ(meta["seed"], 1);
  EXPECT_EQ(meta["pairs"], 3);
  EXPECT_TRUE(meta["assessment"].contains("liu"));
}

TEST_F(BenchSmokeTest, BadArgumentsExitWithTwo) {
  std::string output;
  EXPECT_EQ(
      RunBench("--scene stairs_ramp_room --out '" + dir_.string() + "' --methods strata,astar",
               &output),
      2);
  EXPECT_THAT(output, HasSubstr("unknown method 'astar'"));
  output.clear();
  EXPECT_EQ(RunBench("--scene stairs_ramp_room --pairs 3", &output), 2);
  EXPECT_THAT(output, HasSubstr("--out is required"));
  output.clear();
  EXPECT_EQ(RunBench("--scene stairs_ramp_room --map x.pcd --out '" + dir_.string() + "'", &output),
            2);
  EXPECT_THAT(output, HasSubstr("Exactly 1 option from [--scene,--map]"));
  output.clear();
  EXPECT_EQ(RunBench("--scene stairs_ramp_room --pairs 0 --out '" + dir_.string() + "'", &output),
            2);
  EXPECT_THAT(output, HasSubstr("--pairs: must be a number >= 1, got '0'"));
}

TEST_F(BenchSmokeTest, HelpListsEveryFlag) {
  std::string output;
  ASSERT_EQ(RunBench("--help", &output), 0) << output;
  for (const char* flag :
       {"--scene", "--map", "--out", "--pairs", "--seed", "--methods", "--time-limit",
        "--min-separation", "--dump", "--robot", "--krusi-refine", "--resolution", "--radius",
        "--max-tilt-deg", "--threads"}) {
    EXPECT_THAT(output, HasSubstr(flag));
  }
}

}  // namespace
}  // namespace strata
