// Service figures for docs/benchmarks.md ("Service"): plan latency through gRPC against the
// server's own in-process plan time, and throughput with 1, 2, 8 and 32 concurrent clients.
// Talks to a running strata-server that hosts scene20.2 as "s20" and the spiral as "spiral":
//
//   build/server/strata-server --map-root ../shared/maps
//       --preload spiral=spiral0.3_2.pcd,resolution_m=0.2
//       --preload s20=scene20.2.pcd,resolution_m=0.2
//       --listen 127.0.0.1:50099 --metrics-port -1          (one command line)
//   build/bench/server_benchmark --server 127.0.0.1:50099 [--seconds 5] [--runs 5]
//
// Prints markdown tables. Not part of the test path.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "statistics.hpp"
#include "strata/v1/map_service.grpc.pb.h"
#include "strata/v1/planner_service.grpc.pb.h"

namespace {

using Clock = std::chrono::steady_clock;

struct Query {
  const char* name;
  const char* map_id;  // id on the server
  double start[3], goal[3];
};

// Reference queries of ../shared/maps/README.md that plan successfully (docs/benchmarks.md,
// "Planning").
const Query kLatencyQueries[] = {
    {"s2_flat_diag", "s20", {-6, -8, 1}, {16, 16, 1}},
    {"s2_under_deck", "s20", {0, -2, 1}, {13, -2, 1}},
    {"s2_around_walls", "s20", {-5, -8, 1}, {15, -8, 1}},
    {"sp_ground_right", "spiral", {-18, 0, 1.5}, {8, 2, 1.5}},
    {"sp_ground_to_top", "spiral", {-30, -2, 1.5}, {-30, -28, 21.5}},
};

// The throughput mix: the scene20.2 reference queries that plan, in turn.
const Query kMix[] = {kLatencyQueries[0], kLatencyQueries[1], kLatencyQueries[2]};

using strata::bench::Median;
using strata::bench::Quantile;

strata::v1::PlanRequest Request(const Query& q) {
  strata::v1::PlanRequest r;
  r.set_map_id(q.map_id);
  r.set_profile_name("differential");
  auto* s = r.mutable_start()->mutable_position_m();
  s->set_x(q.start[0]);
  s->set_y(q.start[1]);
  s->set_z(q.start[2]);
  auto* g = r.mutable_goal()->mutable_position_m();
  g->set_x(q.goal[0]);
  g->set_y(q.goal[1]);
  g->set_z(q.goal[2]);
  return r;
}

struct Outcome {
  grpc::Status status;
  double rpc_s = 0;    // client-side wall time of the call
  double total_s = 0;  // server-reported stats.timings.total_s
  double queue_s = 0;  // server-reported stats.timings.queue_s
};

Outcome Plan(strata::v1::PlannerService::Stub& stub, const strata::v1::PlanRequest& request) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  strata::v1::PlanResponse response;
  const auto t0 = Clock::now();
  Outcome out;
  out.status = stub.Plan(&context, request, &response);
  out.rpc_s = std::chrono::duration<double>(Clock::now() - t0).count();
  if (out.status.ok()) {
    out.total_s = response.stats().timings().total_s();
    out.queue_s = response.stats().timings().queue_s();
  }
  return out;
}

// Waits until both maps are ACTIVE (the preloads are assessed after the server listens).
bool WaitForMaps(const std::shared_ptr<grpc::Channel>& channel) {
  auto maps = strata::v1::MapService::NewStub(channel);
  const auto until = Clock::now() + std::chrono::minutes(5);
  for (const char* id : {"s20", "spiral"}) {
    for (;;) {
      grpc::ClientContext context;
      context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
      context.set_wait_for_ready(true);
      strata::v1::GetMapRequest request;
      request.set_map_id(id);
      strata::v1::Map map;
      const grpc::Status status = maps->GetMap(&context, request, &map);
      if (status.ok() && map.state() == strata::v1::MAP_STATE_ACTIVE) break;
      if (status.ok() && map.state() != strata::v1::MAP_STATE_CREATING) {
        std::fprintf(stderr, "map %s is neither ACTIVE nor CREATING\n", id);
        return false;
      }
      if (!status.ok() && status.error_code() != grpc::StatusCode::DEADLINE_EXCEEDED &&
          status.error_code() != grpc::StatusCode::UNAVAILABLE) {
        std::fprintf(stderr, "GetMap %s: %s\n", id, status.error_message().c_str());
        return false;
      }
      if (Clock::now() > until) {
        std::fprintf(stderr, "map %s not ACTIVE after 5 minutes\n", id);
        return false;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::string address = "127.0.0.1:50099";
  double seconds = 5;
  int runs = 5;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--server"))
      address = argv[i + 1];
    else if (!std::strcmp(argv[i], "--seconds"))
      seconds = std::atof(argv[i + 1]);
    else if (!std::strcmp(argv[i], "--runs"))
      runs = std::atoi(argv[i + 1]);
    else {
      std::fprintf(stderr, "usage: %s [--server HOST:PORT] [--seconds S] [--runs N]\n", argv[0]);
      return 2;
    }
  }

  auto channel = grpc::CreateChannel(address, grpc::InsecureChannelCredentials());
  if (!WaitForMaps(channel)) return 1;
  auto stub = strata::v1::PlannerService::NewStub(channel);

  // Warm-up: the first plan per profile and map builds the graph; one plan of each query.
  for (const Query& q : kLatencyQueries) {
    const Outcome o = Plan(*stub, Request(q));
    if (!o.status.ok())
      std::fprintf(stderr, "warm-up %s: %d %s\n", q.name, static_cast<int>(o.status.error_code()),
                   o.status.error_message().c_str());
  }

  std::printf("### Latency through gRPC (one client, median of %d)\n\n", runs);
  std::printf(
      "| query | result | RPC ms | in-process ms (stats.timings.total_s) | queue ms | "
      "overhead ms | overhead %% |\n|---|---|---|---|---|---|---|\n");
  for (const Query& q : kLatencyQueries) {
    std::vector<double> rpc, total, queue;
    grpc::Status failed;
    for (int i = 0; i < runs; ++i) {
      const Outcome o = Plan(*stub, Request(q));
      if (!o.status.ok()) {
        failed = o.status;
        continue;
      }
      rpc.push_back(o.rpc_s * 1e3);
      total.push_back(o.total_s * 1e3);
      queue.push_back(o.queue_s * 1e3);
    }
    if (rpc.empty()) {
      std::printf("| %s | code %d: %s | | | | | |\n", q.name, static_cast<int>(failed.error_code()),
                  failed.error_message().c_str());
      continue;
    }
    const double r = Median(rpc), t = Median(total);
    std::printf("| %s | ok %zu/%d | %.2f | %.2f | %.3f | %.2f | %.1f %% |\n", q.name, rpc.size(),
                runs, r, t, Median(queue), r - t, t > 0 ? 100.0 * (r - t) / t : 0.0);
  }

  std::printf(
      "\n### Throughput (mix of s2_flat_diag, s2_under_deck, s2_around_walls; "
      "%.0f s per row)\n\n",
      seconds);
  std::printf(
      "| clients | plans | failed | plans/s | p50 ms | p99 ms | p50 server queue ms |\n"
      "|---|---|---|---|---|---|---|\n");
  for (int clients : {1, 2, 8, 32}) {
    std::atomic<bool> stop{false};
    std::vector<std::vector<double>> lat(clients), queue(clients);
    std::vector<int> failures(clients, 0);
    std::vector<std::thread> threads;
    const auto t0 = Clock::now();
    for (int c = 0; c < clients; ++c) {
      threads.emplace_back([&, c] {
        auto own = strata::v1::PlannerService::NewStub(channel);  // own stub, shared channel
        for (std::size_t i = c; !stop.load(std::memory_order_relaxed); ++i) {
          const Outcome o = Plan(*own, Request(kMix[i % std::size(kMix)]));
          if (stop.load(std::memory_order_relaxed)) break;  // finished after the window
          if (o.status.ok()) {
            lat[c].push_back(o.rpc_s * 1e3);
            queue[c].push_back(o.queue_s * 1e3);
          } else {
            ++failures[c];
          }
        }
      });
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    stop = true;
    const double window = std::chrono::duration<double>(Clock::now() - t0).count();
    for (auto& t : threads) t.join();
    std::vector<double> all, all_queue;
    int failed = 0;
    for (int c = 0; c < clients; ++c) {
      all.insert(all.end(), lat[c].begin(), lat[c].end());
      all_queue.insert(all_queue.end(), queue[c].begin(), queue[c].end());
      failed += failures[c];
    }
    std::printf("| %d | %zu | %d | %.1f | %.1f | %.1f | %.1f |\n", clients, all.size(), failed,
                all.size() / window, Quantile(all, 0.5), Quantile(all, 0.99),
                Quantile(all_queue, 0.5));
    std::fflush(stdout);
  }
  return 0;
}
