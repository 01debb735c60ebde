// `strata batch`: one PlanBatch call with the plan requests of a file (JSON lines), each
// result printed as it arrives.
#include <fstream>

#include <fmt/format.h>

#include "commands.hpp"
#include "connection.hpp"
#include "output.hpp"
#include "strata/client/rpc.hpp"
#include "strata/v1/planner_service.grpc.pb.h"

namespace strata::cli {
namespace {

struct BatchFlags {
  std::string file;
  std::string robot = kDefaultRobot;  ///< For the requests that name no robot.
};

// One PlanRequest per non-blank line, in protobuf's JSON mapping (as grpcurl takes it);
// '#' lines are comments; a request that names no robot gets `robot`, as `strata plan` does.
// UsageError names the file and line of a bad one.
v1::PlanBatchRequest ReadRequests(const std::string& path, const std::string& robot) {
  std::ifstream file(path);
  if (!file) throw UsageError("cannot read \"" + path + "\"");
  v1::PlanBatchRequest batch;
  int number = 0;
  for (std::string line; std::getline(file, line);) {
    ++number;
    const std::size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    v1::PlanRequest* request = batch.add_requests();
    FromJson(line, fmt::format("\"{}\" line {}", path, number), request);
    if (request->robot_case() == v1::PlanRequest::ROBOT_NOT_SET) request->set_profile_name(robot);
  }
  if (batch.requests_size() == 0) throw UsageError("\"" + path + "\" holds no plan request");
  return batch;
}

// One result a line: JSON (compact, so the output is JSON lines too) or a summary.
void PrintResult(const Context& ctx, const v1::PlanBatchRequest& batch,
                 const v1::PlanBatchResponse& item) {
  std::ostream& out = *ctx.out;
  if (ctx.json) {
    out << ToJsonLine(item);
    return;
  }
  const int index = static_cast<int>(item.index());
  out << "plan " << index << " (map "
      << (index < batch.requests_size() ? batch.requests(index).map_id() : std::string("?"))
      << "): ";
  if (item.has_response()) {
    const v1::PlanStats& stats = item.response().stats();
    out << Fixed(stats.length_m(), 2) << " m in " << Fixed(stats.duration_s(), 2) << " s, "
        << stats.pieces() << " pieces, planned in " << Fixed(stats.timings().total_s() * 1e3, 1)
        << " ms\n";
    return;
  }
  const client::RpcError error = client::DescribeStatus(
      grpc::Status(static_cast<grpc::StatusCode>(item.error().code()), item.error().message(),
                   item.error().SerializeAsString()));
  out << "failed: " << error.code_name << ": " << error.message;
  if (!error.reason.empty()) out << " (" << error.reason << ")";
  out << "\n";
}

int RunBatch(const Context& ctx, const BatchFlags& flags) {
  const v1::PlanBatchRequest batch = ReadRequests(flags.file, flags.robot);
  auto stub = v1::PlannerService::NewStub(OpenChannel(ctx));
  grpc::ClientContext call;
  PrepareCall(ctx, &call);
  auto reader = stub->PlanBatch(&call, batch);
  v1::PlanBatchResponse item;
  int failed = 0, received = 0;
  while (reader->Read(&item)) {
    ++received;
    failed += item.has_error();
    PrintResult(ctx, batch, item);
  }
  const grpc::Status status = reader->Finish();
  if (!status.ok()) return ReportRpcError(ctx, "PlanBatch", status);
  if (!ctx.json) {
    *ctx.err << "strata: " << received - failed << " of " << batch.requests_size()
             << " plans succeeded\n";
  }
  return failed == 0 ? kExitOk : kExitRpcError;
}

}  // namespace

void AddBatchCommand(CLI::App& app, const Context& ctx, Command* run) {
  auto [command, flags] = AddCommand<BatchFlags>(
      app, "batch",
      "PlanBatch: the plan requests of FILE (one PlanRequest in JSON a line), results as they "
      "come",
      run, [&ctx](const BatchFlags& flags) { return RunBatch(ctx, flags); });
  command->add_option("FILE", flags->file, "file of plan requests, one JSON PlanRequest a line")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--robot", flags->robot, "robot profile of the requests that name none")
      ->type_name("NAME")
      ->capture_default_str();
}

}  // namespace strata::cli
