#include "compare/bench_command.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>

#include <nlohmann/json.hpp>

#include "baselines/krusi_planner.hpp"
#include "compare/bench_methods.hpp"
#include "compare/bench_pairs.hpp"
#include "compare/bench_report.hpp"
#include "offline/command_line.hpp"
#include "strata/scenes/map_source.hpp"

namespace strata::bench {
namespace {

using Clock = std::chrono::steady_clock;

struct BenchArgs {
  std::string map;  // A MAP argument as map_source takes it.
  AssessmentConfig assessment;
  int pairs = 20;
  std::uint32_t seed = 1;
  std::vector<std::string> methods = {"strata", "liu", "krusi"};
  std::string out_dir;
  double time_limit_s = 2.0;
  double min_separation_m = 1.0;
  int dump = 20;
  std::string robot = "differential";
  double krusi_refine_s = -1;  // < 0: the baseline's default.
};

int Fail(const std::string& what, const Error& error) {
  std::fprintf(stderr, "strata-bench: %s: %s: %s\n", what.c_str(), ErrorCodeName(error.code),
               error.message.c_str());
  return offline::kExitFailed;
}

nlohmann::json MetaJson(const BenchArgs& args, const std::vector<std::string>& command,
                        const std::vector<const BenchMethod*>& methods, std::size_t points,
                        std::size_t pairs) {
  nlohmann::json assessment = nlohmann::json::object();
  for (const BenchMethod* m : methods) {
    assessment[m->name()] = {{"t_a_s", m->assessment_s()}, {"detail", m->assessment_detail()}};
  }
  return {{"command", command},
          {"map", args.map},
          {"points", points},
          {"pairs", pairs},
          {"seed", args.seed},
          {"robot", args.robot},
          {"time_limit_s", args.time_limit_s},
          {"min_separation_m", args.min_separation_m},
          {"krusi_refine_s", args.krusi_refine_s},
          {"strata_resolution_m", args.assessment.grid.resolution_m},
          {"assessment", assessment}};
}

int RunBench(const BenchArgs& parsed, const std::vector<std::string>& command) {
  // The name passed BuiltinRobotName when parsed.
  const Expected<RobotProfile> profile = BuiltinProfile(parsed.robot);
  if (!profile) return Fail("robot", profile.error());
  std::error_code ec;
  std::filesystem::create_directories(parsed.out_dir, ec);
  if (ec) {
    std::fprintf(stderr, "strata-bench: cannot create '%s': %s\n", parsed.out_dir.c_str(),
                 ec.message().c_str());
    return offline::kExitFailed;
  }

  const Expected<MapSource> source = ParseMapSource(parsed.map);
  if (!source) return Fail("loading " + parsed.map, source.error());
  const Expected<LoadedCloud> cloud = LoadMapSource(*source);
  if (!cloud) return Fail("loading " + parsed.map, cloud.error());
  const PointCloud& points = cloud->points;

  // Strata is always assessed: the pairs are drawn from its graph.
  auto begin = Clock::now();
  auto model = TerrainModel::Assess(points, parsed.assessment);
  if (!model) return Fail("assessing " + parsed.map, model.error());
  auto map = std::make_shared<const PlanningMap>(std::move(model).value());
  const double assess_s = std::chrono::duration<double>(Clock::now() - begin).count();
  begin = Clock::now();
  const auto graph = map->Graph(profile->Traversability());
  if (!graph) return Fail("building the graph", graph.error());
  const double graph_s = std::chrono::duration<double>(Clock::now() - begin).count();
  const std::vector<QueryPair> pairs =
      DrawQueryPairs(**graph, parsed.pairs, parsed.seed, parsed.min_separation_m);
  if (pairs.empty()) {
    return Fail("drawing pairs", Error{ErrorCode::kNoPath, "the map has no traversable ground"});
  }

  std::vector<std::unique_ptr<BenchMethod>> methods;
  for (const std::string& name : parsed.methods) {
    if (name == "strata") {
      char detail[128];
      std::snprintf(detail, sizeof(detail), "assess_s=%.4f graph_s=%.4f", assess_s, graph_s);
      methods.push_back(MakeStrataMethod(map, *profile, assess_s + graph_s, detail));
      continue;
    }
    auto method = name == "liu" ? MakeLiuMethod(points, *profile, parsed.assessment.num_threads)
                                : MakeKrusiMethod(points, *profile, parsed.krusi_refine_s);
    if (!method) {
      // Reported as every query failing with this reason, not as a broken run.
      std::fprintf(stderr, "bench: %s could not assess the map: %s\n", name.c_str(),
                   method.error().message.c_str());
      methods.push_back(MakeFailedMethod(name == "liu" ? "liu" : "krusi", method.error()));
      continue;
    }
    methods.push_back(std::move(method).value());
  }
  baselines::KrusiPlanner::SeedRandom(parsed.seed);
  std::vector<const BenchMethod*> method_view;
  for (const auto& m : methods) {
    method_view.push_back(m.get());
    std::fprintf(stderr, "bench: %s t_a %.3f s (%s)\n", m->name(), m->assessment_s(),
                 m->assessment_detail().c_str());
  }

  std::vector<BenchRow> rows;
  const int progress_every = std::max<int>(1, static_cast<int>(pairs.size()) / 20);
  for (std::size_t q = 0; q < pairs.size(); ++q) {
    for (const auto& m : methods) {
      BenchRow row;
      row.query = static_cast<int>(q);
      row.method = m->name();
      row.pair = pairs[q];
      row.outcome = m->Run(pairs[q], parsed.time_limit_s);
      if (row.query >= parsed.dump) row.outcome.points_m.clear();  // Keep memory bounded.
      rows.push_back(std::move(row));
    }
    if ((q + 1) % progress_every == 0) {
      std::fprintf(stderr, "bench: %zu/%zu queries\n", q + 1, pairs.size());
    }
  }

  const std::vector<MethodSummary> summary = Summarize(rows, method_view);
  const std::string markdown = SummaryMarkdown(parsed.map, summary);
  const std::filesystem::path dir(parsed.out_dir);
  for (const Status& s : {WriteResultsCsv((dir / "results.csv").string(), parsed.map, rows),
                          WriteSummaryCsv((dir / "summary.csv").string(), parsed.map, summary),
                          WritePathsCsv((dir / "paths.csv").string(), rows, parsed.dump),
                          WriteCloudCsv((dir / "cloud.csv").string(), points, 150000)}) {
    if (!s) return Fail("writing the results", s.error());
  }
  std::ofstream meta(dir / "meta.json");
  meta << MetaJson(parsed, command, method_view, points.size(), pairs.size()).dump(2) << '\n';
  std::ofstream md(dir / "summary.md");
  md << markdown;
  if (!meta || !md) {
    return Fail("writing the results",
                Error{ErrorCode::kInvalidInput, "cannot write meta.json or summary.md"});
  }
  std::printf("%s", markdown.c_str());
  return offline::kExitOk;
}

}  // namespace

void AddBenchOptions(CLI::App& app, std::vector<std::string> command_line,
                     std::function<int()>* run) {
  auto args = std::make_shared<BenchArgs>();
  // Exactly one of --scene and --map.
  CLI::Option_group* source = app.add_option_group("map", "where the points come from");
  source
      ->add_option_function<std::string>(
          "--scene", [args](const std::string& name) { args->map = "scene:" + name; },
          "a built-in scene: NAME[:SEED][:size_m=M][:spacing_m=M], what follows scene: in a "
          "map source (docs/scenes.md)")
      ->type_name("NAME");
  source->add_option("--map", args->map, "a .pcd, .ply, .bt or .ot file")->type_name("FILE");
  source->require_option(1);
  app.add_option("--out", args->out_dir,
                 "directory for results.csv, summary.csv, summary.md, paths.csv, cloud.csv and "
                 "meta.json")
      ->type_name("DIR")
      ->required();
  app.add_option("--pairs", args->pairs, "random start/goal pairs")
      ->type_name("N")
      ->check(offline::AtLeast(1))
      ->capture_default_str();
  app.add_option("--seed", args->seed, "seed of the pairs and of OMPL's generators")
      ->type_name("S")
      ->capture_default_str();
  app.add_option("--methods", args->methods, "the planners to compare")
      ->type_name("LIST")
      ->delimiter(',')
      ->check(CLI::Validator(
          [](const std::string& method) -> std::string {
            if (method == "strata" || method == "liu" || method == "krusi") return {};
            return "unknown method '" + method + "' (known: strata, liu, krusi)";
          },
          ""))
      ->default_str("strata,liu,krusi");
  app.add_option("--time-limit", args->time_limit_s, "every method's budget per query [s]")
      ->type_name("S")
      ->check(offline::AtLeast(0.001))
      ->capture_default_str();
  app.add_option("--min-separation", args->min_separation_m,
                 "least straight-line distance between start and goal [m]")
      ->type_name("M")
      ->check(offline::AtLeast(0))
      ->capture_default_str();
  app.add_option("--dump", args->dump, "queries whose paths go into paths.csv")
      ->type_name("N")
      ->check(offline::AtLeast(0))
      ->capture_default_str();
  app.add_option("--robot", args->robot, "built-in robot profile: " + offline::BuiltinRobotNames())
      ->type_name("NAME")
      ->check(offline::BuiltinRobotName())
      ->capture_default_str();
  app.add_option("--krusi-refine", args->krusi_refine_s,
                 "seconds of each query's limit the Krusi-style baseline keeps for refining "
                 "[s]; default: the baseline's own")
      ->type_name("S")
      ->check(offline::AtLeast(0));
  offline::AddAssessmentOptions(app, &args->assessment);
  app.callback([args, command_line = std::move(command_line), run] {
    *run = [args, command_line] { return RunBench(*args, command_line); };
  });
}

}  // namespace strata::bench
