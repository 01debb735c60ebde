// Flags and their environment variables, --help, and the READMEs' flag tables against the code.
#include "ops/flags.hpp"

#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace strata::server {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

// Clears every flag's variable and sets `values`, for the guard's lifetime; restores the
// process environment afterwards.
class ScopedEnvironment {
 public:
  explicit ScopedEnvironment(const std::map<std::string, std::string>& values) {
    for (const FlagInfo& flag : DescribeFlags()) Set(flag.env, nullptr);
    for (const auto& [name, value] : values) Set(name, value.c_str());
  }
  ~ScopedEnvironment() {
    for (const auto& [name, value] : saved_) {
      if (value) {
        ::setenv(name.c_str(), value->c_str(), 1);
      } else {
        ::unsetenv(name.c_str());
      }
    }
  }
  ScopedEnvironment(const ScopedEnvironment&) = delete;
  ScopedEnvironment& operator=(const ScopedEnvironment&) = delete;

 private:
  void Set(const std::string& name, const char* value) {
    if (saved_.count(name) == 0) {
      const char* old = std::getenv(name.c_str());
      saved_[name] = old ? std::optional<std::string>(old) : std::nullopt;
    }
    if (value) {
      ::setenv(name.c_str(), value, 1);
    } else {
      ::unsetenv(name.c_str());
    }
  }
  std::map<std::string, std::optional<std::string>> saved_;
};

FlagsOutcome Parse(std::vector<const char*> args, std::map<std::string, std::string> env = {}) {
  ScopedEnvironment environment(env);
  args.insert(args.begin(), "strata-server");
  return ParseFlags(static_cast<int>(args.size()), args.data());
}

TEST(FlagsTest, DefaultsPreloadTheDemoScene) {
  const FlagsOutcome outcome = Parse({});
  ASSERT_EQ(outcome.action, FlagsOutcome::Action::kRun);
  EXPECT_EQ(outcome.config.listen, "0.0.0.0:50051");
  EXPECT_EQ(outcome.config.metrics_port, 9090);
  EXPECT_EQ(outcome.config.http_port, -1);  // The viewer is off unless asked for.
  EXPECT_TRUE(outcome.config.map_root.empty());
  ASSERT_EQ(outcome.config.preload.size(), 1u);
  EXPECT_EQ(outcome.config.preload[0].id, "demo");
  // The demo scene as strata-offline's scene:two_level_ramp: the default seed and options.
  ASSERT_TRUE(outcome.config.preload[0].scene.has_value());
  EXPECT_EQ(outcome.config.preload[0].scene->name, "two_level_ramp");
  EXPECT_EQ(outcome.config.preload[0].scene->seed, kDefaultSceneSeed);
  EXPECT_FALSE(outcome.config.preload[0].scene->options.size_m.has_value());
  EXPECT_FALSE(outcome.config.preload[0].scene->options.spacing_m.has_value());
  EXPECT_EQ(outcome.config.max_concurrent_assessments, 1);
}

TEST(FlagsTest, FlagsOverrideTheEnvironment) {
  const FlagsOutcome outcome = Parse(
      {"--listen", "127.0.0.1:0", "--max-plan-time-s=2.5"},
      {{"STRATA_LISTEN", "1.2.3.4:5"}, {"STRATA_MAP_ROOT", "/maps"}, {"STRATA_METRICS_PORT", "0"}});
  ASSERT_EQ(outcome.action, FlagsOutcome::Action::kRun) << outcome.text;
  EXPECT_EQ(outcome.config.listen, "127.0.0.1:0");
  EXPECT_EQ(outcome.config.map_root, "/maps");
  EXPECT_EQ(outcome.config.metrics_port, 0);
  EXPECT_DOUBLE_EQ(outcome.config.max_plan_time_s, 2.5);
  // A negative number is a value, not a flag (tests/deploy disables metrics so).
  EXPECT_EQ(Parse({"--metrics-port", "-1"}).config.metrics_port, -1);
  // The viewer as scripts/run.sh and the image turn it on, an argument moving it.
  EXPECT_EQ(Parse({}, {{"STRATA_HTTP_PORT", "8080"}}).config.http_port, 8080);
  EXPECT_EQ(Parse({"--http-port", "0"}, {{"STRATA_HTTP_PORT", "8080"}}).config.http_port, 0);
  EXPECT_EQ(Parse({"--http-address", "127.0.0.1"}).config.http_address, "127.0.0.1");
}

TEST(FlagsTest, EveryFlagReadsItsVariable) {
  const FlagsOutcome outcome = Parse({}, {{"STRATA_MAX_MAPS", "3"},
                                          {"STRATA_MAX_PLAN_TIME_S", "1.5"},
                                          {"STRATA_MAX_POINTS", "1000"},
                                          {"STRATA_SHUTDOWN_GRACE_S", "0"},
                                          {"STRATA_LOG_LEVEL", "warn"},
                                          {"STRATA_KEEPALIVE_TIME_S", "7"}});
  ASSERT_EQ(outcome.action, FlagsOutcome::Action::kRun) << outcome.text;
  EXPECT_EQ(outcome.config.max_maps, 3);
  EXPECT_DOUBLE_EQ(outcome.config.max_plan_time_s, 1.5);
  EXPECT_EQ(outcome.config.max_points, 1000u);
  EXPECT_EQ(outcome.config.shutdown_grace_s, 0.0);
  EXPECT_EQ(outcome.config.log_level, LogLevel::kWarning);
  EXPECT_EQ(outcome.config.keepalive_time_s, 7.0);
  // An empty variable counts as unset.
  EXPECT_EQ(Parse({}, {{"STRATA_MAX_MAPS", ""}}).config.max_maps, ServerConfig{}.max_maps);
}

TEST(FlagsTest, PreloadsReplaceTheDemoAndNoPreloadEmptiesTheList) {
  FlagsOutcome outcome = Parse({"--preload", "spiral=spiral0.3_2.pcd,resolution_m=0.3", "--preload",
                                "room=scene:stairs_ramp_room:7"});
  ASSERT_EQ(outcome.action, FlagsOutcome::Action::kRun) << outcome.text;
  ASSERT_EQ(outcome.config.preload.size(), 2u);
  EXPECT_EQ(outcome.config.preload[0].path, "spiral0.3_2.pcd");
  EXPECT_DOUBLE_EQ(*outcome.config.preload[0].resolution_m, 0.3);
  ASSERT_TRUE(outcome.config.preload[1].scene.has_value());
  EXPECT_EQ(outcome.config.preload[1].scene->name, "stairs_ramp_room");
  EXPECT_EQ(outcome.config.preload[1].scene->seed, 7u);
  EXPECT_FALSE(outcome.config.preload[0].scene.has_value());

  // Scene options, read by ParseSceneSource; the assessment keys follow the commas.
  outcome =
      Parse({"--preload", "site=scene:outdoor_site:2:size_m=60:spacing_m=0.2,resolution_m=0.3"});
  ASSERT_EQ(outcome.action, FlagsOutcome::Action::kRun) << outcome.text;
  const PreloadSpec& site = outcome.config.preload.at(0);
  ASSERT_TRUE(site.scene.has_value());
  EXPECT_EQ(site.scene->name, "outdoor_site");
  EXPECT_EQ(site.scene->seed, 2u);
  EXPECT_EQ(site.scene->options.size_m, 60.0);
  EXPECT_EQ(site.scene->options.spacing_m, 0.2);
  EXPECT_EQ(site.resolution_m, 0.3);

  outcome = Parse({}, {{"STRATA_PRELOAD", "a=scene:uneven_terrain b=x.pcd"}});
  ASSERT_EQ(outcome.config.preload.size(), 2u);
  EXPECT_EQ(outcome.config.preload[1].id, "b");

  outcome = Parse({"--no-preload"});
  ASSERT_EQ(outcome.action, FlagsOutcome::Action::kRun);
  EXPECT_TRUE(outcome.config.preload.empty());
}

TEST(FlagsTest, PreloadFlagsBeatTheOtherVariable) {
  // --no-preload empties the variable's list (compose.yaml always sets STRATA_PRELOAD).
  FlagsOutcome outcome = Parse({"--no-preload"}, {{"STRATA_PRELOAD", "a=scene:uneven_terrain"}});
  ASSERT_EQ(outcome.action, FlagsOutcome::Action::kRun) << outcome.text;
  EXPECT_TRUE(outcome.config.preload.empty());
  // --preload wins over STRATA_NO_PRELOAD.
  outcome = Parse({"--preload", "a=scene:uneven_terrain"}, {{"STRATA_NO_PRELOAD", "1"}});
  ASSERT_EQ(outcome.action, FlagsOutcome::Action::kRun) << outcome.text;
  ASSERT_EQ(outcome.config.preload.size(), 1u);
  EXPECT_EQ(outcome.config.preload[0].id, "a");
  // STRATA_NO_PRELOAD beats STRATA_PRELOAD; a false value is no --no-preload.
  EXPECT_TRUE(Parse({}, {{"STRATA_NO_PRELOAD", "true"}, {"STRATA_PRELOAD", "a=x.pcd"}})
                  .config.preload.empty());
  EXPECT_EQ(Parse({}, {{"STRATA_NO_PRELOAD", "0"}}).config.preload.size(), 1u);
  // Both on the command line contradict each other.
  outcome = Parse({"--preload", "a=x.pcd", "--no-preload"});
  EXPECT_EQ(outcome.action, FlagsOutcome::Action::kError);
  EXPECT_THAT(outcome.text, HasSubstr("--no-preload"));
  EXPECT_THAT(outcome.text, HasSubstr("--preload"));
}

TEST(FlagsTest, ErrorsNameTheFlag) {
  EXPECT_THAT(Parse({"--bogus"}).text, HasSubstr("--bogus"));
  EXPECT_THAT(Parse({"stray"}).text, HasSubstr("stray"));
  EXPECT_THAT(Parse({"--max-maps", "0"}).text, HasSubstr("--max-maps"));
  EXPECT_THAT(Parse({"--max-plan-time-s", "-1"}).text, HasSubstr("--max-plan-time-s"));
  const std::string missing = Parse({"--listen"}).text;
  EXPECT_THAT(missing, HasSubstr("--listen"));
  EXPECT_THAT(missing, HasSubstr("missing"));
  EXPECT_THAT(Parse({"--preload", "nosource"}).text, HasSubstr("ID=SOURCE"));
  EXPECT_THAT(Parse({"--preload", "a=b.pcd,speed=3"}).text, HasSubstr("speed=3"));
  EXPECT_THAT(Parse({}, {{"STRATA_MAX_MAPS", "x"}}).text, HasSubstr("STRATA_MAX_MAPS"));
  EXPECT_EQ(Parse({"--help"}).action, FlagsOutcome::Action::kHelp);
  EXPECT_EQ(Parse({"-h"}).action, FlagsOutcome::Action::kHelp);
  EXPECT_EQ(Parse({"--version"}).action, FlagsOutcome::Action::kVersion);
}

TEST(FlagsTest, BadValuesAreRefusedWithTheValue) {
  struct Case {
    std::vector<const char*> args;
    const char* message;
  };
  for (const Case& c : std::vector<Case>{
           {{"--listen", "50051"}, "'50051' is not HOST:PORT"},
           {{"--metrics-port", "70000"}, "70000"},
           {{"--metrics-port", "-2"}, "-2"},
           {{"--metrics-address", "0.0.0.0:9090"}, "(no port: see --metrics-port)"},
           {{"--http-port", "65536"}, "65536"},
           {{"--http-address", "0.0.0.0:8080"}, "(no port: see --http-port)"},
           {{"--max-assessment-time-s", "0"}, "'0' is not a number of seconds > 0"},
           {{"--max-assessment-memory", "1000"}, "--max-assessment-memory"},
           {{"--max-points", "0"}, "--max-points"},
           {{"--max-receive-message-bytes", "1048576"}, "1048576"},
           {{"--max-plan-time-s", "nan"}, "'nan' is not a number of seconds > 0"},
           {{"--keepalive-time-s", "0"}, "'0' is not a number of seconds > 0"},
           {{"--shutdown-grace-s", "-0.5"}, "'-0.5' is not a number of seconds >= 0"},
           {{"--log-level", "loud"}, "'loud' is not a log level"},
           {{"--preload", "a=scene:x:-1"}, "the seed must be an integer"},
           {{"--preload", "a=scene:"}, "NAME is missing"},
           {{"--preload", "a=scene:x:size_m=big"}, "size_m must be a decimal number"},
           {{"--preload", "a=scene:x:colour=red"}, "unknown option 'colour'"},
           {{"--preload", "a=x.pcd", "b=y.pcd"}, "b=y.pcd"},
       }) {
    const FlagsOutcome outcome = Parse(c.args);
    EXPECT_EQ(outcome.action, FlagsOutcome::Action::kError) << c.args[0];
    EXPECT_THAT(outcome.text, HasSubstr(c.message)) << c.args[0];
  }
  // The same values from a variable: the message names the variable, once it is its value.
  for (const auto& [env, value] : std::vector<std::pair<std::string, std::string>>{
           {"STRATA_LISTEN", "50051"},
           {"STRATA_METRICS_PORT", "x"},
           {"STRATA_MAX_PLAN_TIME_S", "inf"},
           {"STRATA_LOG_LEVEL", "loud"},
           {"STRATA_PRELOAD", "a=x.pcd nosource"},
           {"STRATA_NO_PRELOAD", "banana"},
       }) {
    const FlagsOutcome outcome = Parse({}, {{env, value}});
    EXPECT_EQ(outcome.action, FlagsOutcome::Action::kError) << env;
    EXPECT_THAT(outcome.text, HasSubstr("(from " + env + ")")) << env;
  }
  // A good flag over a bad variable: the variable is never read.
  EXPECT_EQ(Parse({"--max-maps", "2"}, {{"STRATA_MAX_MAPS", "x"}}).action,
            FlagsOutcome::Action::kRun);
  // A bad flag is blamed on the flag even when its variable is set.
  EXPECT_THAT(Parse({"--max-maps", "0"}, {{"STRATA_MAX_MAPS", "3"}}).text,
              Not(HasSubstr("STRATA_MAX_MAPS")));
}

TEST(FlagsTest, HelpListsEveryFlagWithItsDefaultAndVariable) {
  const std::vector<FlagInfo> flags = DescribeFlags();
  ASSERT_EQ(flags.size(), 48u);
  const FlagsOutcome help = Parse({"--help"});
  EXPECT_EQ(help.text, UsageText());
  for (const FlagInfo& flag : flags) {
    EXPECT_EQ(
        flag.env, "STRATA_" + [&] {
          std::string upper;
          for (char c : flag.name.substr(2))
            upper += c == '-' ? '_' : static_cast<char>(std::toupper(c));
          return upper;
        }());
    EXPECT_THAT(help.text, HasSubstr("\n  " + flag.name + " ")) << flag.name;
    EXPECT_THAT(help.text, HasSubstr("env " + flag.env + "]")) << flag.name;
    if (!flag.default_text.empty()) {
      // The range too, unless the placeholder says it already.
      const std::string range =
          flag.range.empty() || flag.range == flag.placeholder ? "" : flag.range + ", ";
      EXPECT_THAT(help.text,
                  HasSubstr("[default " + flag.default_text + ", " + range + "env " + flag.env))
          << flag.name;
    }
  }
  // The defaults --help prints are ServerConfig's.
  const ServerConfig defaults;
  std::map<std::string, std::string> by_name;
  for (const FlagInfo& flag : flags) by_name[flag.name] = flag.default_text;
  EXPECT_EQ(by_name["--listen"], defaults.listen);
  EXPECT_EQ(by_name["--max-points"], std::to_string(defaults.max_points));
  EXPECT_EQ(by_name["--max-maps"], std::to_string(defaults.max_maps));
  EXPECT_EQ(by_name["--preload"], kDefaultPreload);
  EXPECT_EQ(by_name["--log-level"], "info");
  EXPECT_EQ(by_name["--map-root"], "");
}

// A flag's row of server/README.md's "Flags" table, its cells without backticks: the flag
// with its placeholder, the default ("none" for none), the range, the variable, the meaning.
struct ReadmeRow {
  std::string flag;
  std::string default_text;
  std::string range;
  std::string env;
};

std::map<std::string, ReadmeRow> ReadmeFlagRows() {
  std::ifstream file(std::string(STRATA_SOURCE_DIR) + "/server/README.md");
  EXPECT_TRUE(file);
  std::map<std::string, ReadmeRow> rows;
  bool in_section = false;
  for (std::string line; std::getline(file, line);) {
    if (line.rfind('#', 0) == 0) in_section = line.find("## Flags") != std::string::npos;
    if (!in_section || line.rfind("| `--", 0) != 0) continue;
    std::vector<std::string> cells;
    std::istringstream row(line.substr(1));
    for (std::string cell; std::getline(row, cell, '|');) {
      std::erase(cell, '`');
      cell.erase(0, cell.find_first_not_of(' '));
      cell.erase(cell.find_last_not_of(' ') + 1);
      cells.push_back(cell);
    }
    EXPECT_GE(cells.size(), 5u) << line;
    if (cells.size() < 5) continue;
    rows[cells[0].substr(0, cells[0].find(' '))] = {cells[0], cells[1] == "none" ? "" : cells[1],
                                                    cells[2] == "-" ? "" : cells[2], cells[3]};
  }
  EXPECT_FALSE(rows.empty()) << "no flag table under \"## Flags\" in server/README.md";
  return rows;
}

// The table is what the code says, in full: every flag, with its placeholder, default, range
// and variable, in --help's order.
TEST(FlagsTest, TheReadmeTableIsTheFlagTable) {
  const std::map<std::string, ReadmeRow> rows = ReadmeFlagRows();
  std::size_t rows_seen = 0;
  for (const FlagInfo& flag : DescribeFlags()) {
    const std::string expected =
        "| `" + flag.name + (flag.placeholder.empty() ? "" : " " + flag.placeholder) + "` | " +
        (flag.default_text.empty() ? "none" : "`" + flag.default_text + "`") + " | " +
        (flag.range.empty() ? "-" : flag.range) + " | `" + flag.env + "` | ...";
    const auto row = rows.find(flag.name);
    ASSERT_NE(row, rows.end()) << flag.name << " is missing from server/README.md: " << expected;
    ++rows_seen;
    EXPECT_EQ(row->second.flag,
              flag.name + (flag.placeholder.empty() ? "" : " " + flag.placeholder))
        << expected;
    EXPECT_EQ(row->second.default_text, flag.default_text) << expected;
    EXPECT_EQ(row->second.range, flag.range) << expected;
    EXPECT_EQ(row->second.env, flag.env) << expected;
  }
  EXPECT_EQ(rows.size(), rows_seen) << "server/README.md lists a flag strata-server lacks";
}

}  // namespace
}  // namespace strata::server
