#include "compare/bench_command.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "baselines/krusi_planner.hpp"
#include "compare/bench_methods.hpp"
#include "compare/bench_pairs.hpp"
#include "compare/bench_report.hpp"
#include "offline/assessment_options.hpp"
#include "strata/scenes/map_source.hpp"

namespace strata::bench {
namespace {

using offline::IsAssessmentOption;
using offline::ParseNumber;
using offline::TakeAssessmentOption;

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

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    if (!item.empty()) items.push_back(item);
  }
  return items;
}

std::optional<std::string> ParseArgs(const std::vector<std::string>& args, BenchArgs* out) {
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (IsAssessmentOption(a)) {
      if (auto problem = TakeAssessmentOption(args, &i, &out->assessment)) return problem;
      continue;
    }
    if (!a.starts_with("--")) return "unexpected argument '" + a + "'";
    if (i + 1 >= args.size()) return a + " needs a value";
    const std::string& value = args[++i];
    const std::optional<double> number = ParseNumber(value);
    auto need_number = [&](double low) -> std::optional<std::string> {
      if (!number || *number < low) {
        return a + " needs a number >= " + std::to_string(low) + ", got '" + value + "'";
      }
      return std::nullopt;
    };
    if (a == "--scene" || a == "--map") {
      if (!out->map.empty()) return "give one of --scene and --map, once";
      out->map = a == "--scene" ? "scene:" + value : value;
    } else if (a == "--pairs") {
      if (auto p = need_number(1)) return p;
      out->pairs = static_cast<int>(*number);
    } else if (a == "--seed") {
      if (auto p = need_number(0)) return p;
      out->seed = static_cast<std::uint32_t>(*number);
    } else if (a == "--time-limit") {
      if (auto p = need_number(0.001)) return p;
      out->time_limit_s = *number;
    } else if (a == "--min-separation") {
      if (auto p = need_number(0)) return p;
      out->min_separation_m = *number;
    } else if (a == "--dump") {
      if (auto p = need_number(0)) return p;
      out->dump = static_cast<int>(*number);
    } else if (a == "--methods") {
      out->methods = SplitList(value);
      for (const std::string& m : out->methods) {
        if (m != "strata" && m != "liu" && m != "krusi") {
          return "unknown method '" + m + "' (known: strata, liu, krusi)";
        }
      }
      if (out->methods.empty()) return "--methods needs at least one of strata, liu, krusi";
    } else if (a == "--out") {
      out->out_dir = value;
    } else if (a == "--krusi-refine") {
      if (auto p = need_number(0)) return p;
      out->krusi_refine_s = *number;
    } else if (a == "--robot") {
      out->robot = value;
    } else {
      return "unknown option " + a;
    }
  }
  if (out->map.empty()) return "--scene NAME or --map FILE is missing";
  if (out->out_dir.empty()) return "--out DIR is missing";
  return std::nullopt;
}

int Fail(const std::string& what, const Error& error) {
  std::fprintf(stderr, "strata-bench: %s: %s: %s\n", what.c_str(), ErrorCodeName(error.code),
               error.message.c_str());
  return 1;
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

}  // namespace

int RunBench(const std::vector<std::string>& args) {
  BenchArgs parsed;
  if (auto problem = ParseArgs(args, &parsed)) {
    std::fprintf(stderr, "strata-bench: %s\n", problem->c_str());
    return 2;
  }
  const Expected<RobotProfile> profile = BuiltinProfile(parsed.robot);
  if (!profile) {
    std::fprintf(stderr, "strata-bench: %s\n", profile.error().message.c_str());
    return 2;
  }
  std::error_code ec;
  std::filesystem::create_directories(parsed.out_dir, ec);
  if (ec) {
    std::fprintf(stderr, "strata-bench: cannot create '%s': %s\n", parsed.out_dir.c_str(),
                 ec.message().c_str());
    return 1;
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
  std::vector<std::string> command = {"strata-bench"};
  command.insert(command.end(), args.begin(), args.end());
  std::ofstream meta(dir / "meta.json");
  meta << MetaJson(parsed, command, method_view, points.size(), pairs.size()).dump(2) << '\n';
  std::ofstream md(dir / "summary.md");
  md << markdown;
  if (!meta || !md) {
    return Fail("writing the results",
                Error{ErrorCode::kInvalidInput, "cannot write meta.json or summary.md"});
  }
  std::printf("%s", markdown.c_str());
  return 0;
}

}  // namespace strata::bench
