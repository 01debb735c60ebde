// `strata costs`: one EstimateCosts call from the points of one file to those of another,
// printed cell by cell or as the EstimateCostsResponse in JSON.
#include <cstring>
#include <optional>

#include <fmt/format.h>

#include "commands.hpp"
#include "connection.hpp"
#include "output.hpp"
#include "point_file.hpp"
#include "strata/v1/planner_service.grpc.pb.h"

namespace strata::cli {
namespace {

struct CostsFlags {
  std::string map;
  std::string from;
  std::string to;
  std::optional<std::string> format;
  std::string robot = kDefaultRobot;
  std::optional<double> snap_tolerance_m;
};

// The points of a file (the formats of `maps upload`; text when the extension says nothing),
// read as float32 like an upload: to a few millimetres, within the planner's ±1e5 m.
void ReadPositions(const std::string& path, const std::optional<std::string>& format_name,
                   google::protobuf::RepeatedPtrField<v1::Vector3>* out) {
  std::optional<PointFileFormat> format =
      format_name ? ParsePointFileFormat(*format_name) : GuessPointFileFormat(path);
  if (!format) format = PointFileFormat::kText;
  PointFileReader reader(path, *format);
  std::string chunk;
  constexpr std::size_t kChunkPoints = 4096;
  while (reader.Next(kChunkPoints, &chunk)) {
    for (std::size_t offset = 0; offset + 12 <= chunk.size(); offset += 12) {
      float xyz[3];
      std::memcpy(xyz, chunk.data() + offset, sizeof(xyz));
      v1::Vector3* p = out->Add();
      p->set_x(xyz[0]);
      p->set_y(xyz[1]);
      p->set_z(xyz[2]);
    }
  }
  if (out->empty()) throw UsageError("\"" + path + "\" holds no point");
}

void PrintEnd(std::ostream& out, const char* what, int index, const v1::Vector3& requested,
              const v1::CostEndpoint& end) {
  out << "  " << what << " " << index << " " << FormatVector(requested);
  if (end.reason().empty()) {
    out << " -> " << FormatVector(end.snapped().position_m()) << ", level " << end.snapped().level()
        << "\n";
  } else {
    out << ": " << end.reason() << ": " << end.message() << "\n";
  }
}

void PrintSummary(const Context& ctx, const v1::EstimateCostsRequest& request,
                  const v1::EstimateCostsResponse& response) {
  std::ostream& out = *ctx.out;
  int reachable = 0;
  for (const v1::CostCell& cell : response.cells()) reachable += cell.reachable();
  out << "costs on map " << request.map_id() << " for robot " << response.profile().name() << ": "
      << request.starts_m_size() << " starts x " << request.goals_m_size() << " goals, "
      << reachable << " reachable (" << Fixed(response.stats().total_s() * 1e3, 1) << " ms, "
      << response.stats().searches() << " searches on " << response.stats().slots_used()
      << " slot(s))\n";
  for (int i = 0; i < response.starts_size(); ++i) {
    PrintEnd(out, "start", i, request.starts_m(i), response.starts(i));
  }
  for (int j = 0; j < response.goals_size(); ++j) {
    PrintEnd(out, "goal ", j, request.goals_m(j), response.goals(j));
  }
  out << "  start  goal      time_s   length_m\n";
  const int goals = response.goals_size();
  for (int k = 0; k < response.cells_size(); ++k) {
    const v1::CostCell& cell = response.cells(k);
    // Explicit right alignment: fmt would left-align inf and nan in a width.
    out << (cell.reachable() ? fmt::format("  {:5} {:5}  {:>10.2f} {:>10.2f}\n", k / goals,
                                           k % goals, cell.time_s(), cell.length_m())
                             : fmt::format("  {:5} {:5}  unreachable: {}\n", k / goals, k % goals,
                                           cell.reason()));
  }
}

int RunCosts(const Context& ctx, const CostsFlags& flags) {
  v1::EstimateCostsRequest request;
  request.set_map_id(flags.map);
  request.set_profile_name(flags.robot);
  if (flags.snap_tolerance_m) request.set_snap_tolerance_m(*flags.snap_tolerance_m);
  ReadPositions(flags.from, flags.format, request.mutable_starts_m());
  ReadPositions(flags.to, flags.format, request.mutable_goals_m());
  auto stub = v1::PlannerService::NewStub(OpenChannel(ctx));
  grpc::ClientContext call;
  PrepareCall(ctx, &call);
  v1::EstimateCostsResponse response;
  const grpc::Status status = stub->EstimateCosts(&call, request, &response);
  if (!status.ok()) return ReportRpcError(ctx, "EstimateCosts", status);
  if (ctx.json) {
    *ctx.out << ToJson(response);
  } else {
    PrintSummary(ctx, request, response);
  }
  return kExitOk;
}

}  // namespace

void AddCostsCommand(CLI::App& app, const Context& ctx, Command* run) {
  auto [costs, flags] = AddCommand<CostsFlags>(
      app, "costs",
      "EstimateCosts: estimated travel time and length from every start to every goal", run,
      [&ctx](const CostsFlags& flags) { return RunCosts(ctx, flags); });
  costs->add_option("--map", flags->map, "map id")->type_name("ID")->required();
  costs->add_option("--from", flags->from, "file of start points x,y,z [m], one a line")
      ->type_name("FILE")
      ->required()
      ->check(CLI::ExistingFile);
  costs->add_option("--to", flags->to, "file of goal points x,y,z [m], one a line")
      ->type_name("FILE")
      ->required()
      ->check(CLI::ExistingFile);
  costs
      ->add_option("--format", flags->format,
                   "format of both files: xyz (text), pcd or raw; default from the extension, "
                   "else text")
      ->type_name("FORMAT")
      ->check(CLI::IsMember({"xyz", "pcd", "raw"}));
  costs->add_option("--robot", flags->robot, "robot profile")
      ->type_name("NAME")
      ->capture_default_str();
  costs->add_option("--snap-tolerance", flags->snap_tolerance_m, "snap_tolerance_m [m]")
      ->type_name("M")
      ->check(FiniteNumber());
}

}  // namespace strata::cli
