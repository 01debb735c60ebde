#include "offline/assess_command.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <nlohmann/json.hpp>

#include "offline/assessed_map.hpp"
#include "offline/command_line.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/io/saved_model.hpp"

namespace strata::offline {
namespace {

struct AssessArgs {
  std::string map;
  AssessmentConfig config;
  bool json = false;
  std::string save_path;
  bool progress = false;
};

nlohmann::json SummaryJson(const std::string& source, const AssessedMap& map) {
  const TerrainModel& model = *map.model;
  const AssessmentSummary& s = model.summary();
  const GridGeometry& g = model.grid();
  const AssessmentTimings& t = s.timings;
  return {
      {"map", source},
      {"points",
       {{"raw", map.raw_point_count},
        {"dropped_nonfinite", map.dropped_nonfinite},
        {"input", s.input_points},
        {"valid_ground", s.valid_ground_points}}},
      {"grid",
       {{"size", {g.size.x(), g.size.y(), g.size.z()}},
        {"cells", g.CellCount()},
        {"resolution_m", g.resolution_m},
        {"origin_m", {g.origin_m.x(), g.origin_m.y(), g.origin_m.z()}}}},
      {"surfaces",
       {{"total", s.surface_count},
        {"valid", s.valid_surface_count},
        {"memory_bytes", model.surfaces().MemoryBytes()}}},
      {"fields",
       {{"cells", model.fields().cell_count()}, {"memory_bytes", model.fields().MemoryBytes()}}},
      {"memory_bytes", model.MemoryBytes()},
      {"from_saved_model", map.from_saved_model},
      {"seconds",
       {{"load", map.load_s},
        {"ground_filter", t.ground_filter_s},
        {"surfaces", t.surfaces_s},
        {"fields", t.fields_s},
        {"total", map.load_s + t.total_s}}},
  };
}

void PrintHuman(const nlohmann::json& j) {
  const auto& p = j["points"];
  const auto& g = j["grid"];
  const auto& s = j["seconds"];
  std::printf("map            %s\n", j["map"].get<std::string>().c_str());
  std::printf("points         %zu raw, %zu dropped (non-finite), %zu valid ground\n",
              p["raw"].get<std::size_t>(), p["dropped_nonfinite"].get<std::size_t>(),
              p["valid_ground"].get<std::size_t>());
  std::printf("grid           %d x %d x %d cells at %.3f m (%lld cells)\n", g["size"][0].get<int>(),
              g["size"][1].get<int>(), g["size"][2].get<int>(), g["resolution_m"].get<double>(),
              g["cells"].get<long long>());
  std::printf("surfaces       %zu, of which %zu valid ground\n",
              j["surfaces"]["total"].get<std::size_t>(), j["surfaces"]["valid"].get<std::size_t>());
  std::printf("memory         %.1f MB (%zu bytes)\n", j["memory_bytes"].get<std::size_t>() / 1.0e6,
              j["memory_bytes"].get<std::size_t>());
  std::printf(
      "seconds        load %.3f, ground filter %.3f, surfaces %.3f, fields %.3f, total %.3f\n",
      s["load"].get<double>(), s["ground_filter"].get<double>(), s["surfaces"].get<double>(),
      s["fields"].get<double>(), s["total"].get<double>());
}

int RunAssess(const AssessArgs& parsed) {
  Expected<AssessedMap> map =
      LoadAndAssess(parsed.map, parsed.config, ProgressLine(parsed.progress));
  if (!map) {
    std::fprintf(stderr, "strata-offline assess: %s: %s\n", ErrorCodeName(map.error().code),
                 map.error().message.c_str());
    // An error that blames a field blames an option given: the command line is at fault.
    const bool blames_option = (map.error().code == ErrorCode::kInvalidInput ||
                                map.error().code == ErrorCode::kInvalidConfig) &&
                               !map.error().field.empty();
    return blames_option ? kExitBadArguments : kExitFailed;
  }
  nlohmann::json summary = SummaryJson(parsed.map, *map);
  if (!parsed.save_path.empty()) {
    const auto start = std::chrono::steady_clock::now();
    if (Status saved = SaveModel(*map->model, parsed.save_path); !saved) {
      std::fprintf(stderr, "strata-offline assess: %s\n", saved.error().message.c_str());
      return kExitFailed;
    }
    std::error_code ignored;
    summary["saved"] = {
        {"path", parsed.save_path},
        {"bytes", std::filesystem::file_size(parsed.save_path, ignored)},
        {"seconds",
         std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()}};
  }
  if (parsed.json) {
    std::printf("%s\n", summary.dump(2).c_str());
  } else {
    PrintHuman(summary);
  }
  return kExitOk;
}

}  // namespace

void AddAssessCommand(CLI::App& app, std::function<int()>* run) {
  auto args = std::make_shared<AssessArgs>();
  CLI::App* command = app.add_subcommand(
      "assess", "Terrain assessment of MAP: point counts, grid, memory and seconds per stage.");
  command->add_option("MAP", args->map, MapHelp())->type_name("")->required();
  AddAssessmentOptions(*command, &args->config);
  command->add_flag("--json", args->json, "print the figures as JSON (README.md lists the keys)");
  command
      ->add_option("--save", args->save_path,
                   "also write the assessed model to FILE (a saved model: every command and "
                   "strata-server take it as a map and load it without assessing)")
      ->type_name("FILE");
  AddProgressFlag(*command, &args->progress);
  command->callback([args, run] { *run = [args] { return RunAssess(*args); }; });
}

}  // namespace strata::offline
