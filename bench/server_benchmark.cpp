// Service figures for docs/benchmarks.md ("Service"): plan latency through gRPC against the
// server's own in-process plan time, and throughput with 1, 2, 8 and 32 concurrent clients.
// Talks to a running strata-server that hosts scene20.2 as "s20" and the spiral as "spiral":
//
//   build/server/strata-server --map-root ../shared/maps
//       --preload spiral=spiral0.3_2.pcd,resolution_m=0.2
//       --preload s20=scene20.2.pcd,resolution_m=0.2
//       --listen 127.0.0.1:50099 --metrics-port -1          (one command line)
//   build/bench/server_benchmark --server 127.0.0.1:50099 [--seconds 5] [--runs 5]
//       [--clients 1,2,8,32] [--mix s2|spiral] [--deadline-s 30]
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

// The throughput mixes, planned in turn: the scene20.2 reference queries that plan, or four
// of the spiral's (each 5-45 ms in-process).
const std::vector<Query> kS2Mix = {kLatencyQueries[0], kLatencyQueries[1], kLatencyQueries[2]};
const std::vector<Query> kSpiralMix = {
    {"sp_ground_left", "spiral", {-38, -2, 1.5}, {-26, -24, 1.5}},
    {"sp_ground_right", "spiral", {-18, 0, 1.5}, {8, 2, 1.5}},
    {"sp_ground_to_l1", "spiral", {-30, -2, 1.5}, {-45, -29, 5.5}},
    {"sp_ground_to_top", "spiral", {-30, -2, 1.5}, {-30, -28, 21.5}},
};

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

Outcome Plan(strata::v1::PlannerService::Stub& stub, const strata::v1::PlanRequest& request,
             double deadline_s = 30) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() +
                       std::chrono::duration_cast<std::chrono::system_clock::duration>(
                           std::chrono::duration<double>(deadline_s)));
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
  double deadline_s = 30;
  std::vector<int> client_counts = {1, 2, 8, 32};
  const std::vector<Query>* mix = &kS2Mix;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!std::strcmp(argv[i], "--server")) {
      address = argv[i + 1];
    } else if (!std::strcmp(argv[i], "--seconds")) {
      seconds = std::atof(argv[i + 1]);
    } else if (!std::strcmp(argv[i], "--runs")) {
      runs = std::atoi(argv[i + 1]);
    } else if (!std::strcmp(argv[i], "--deadline-s")) {
      deadline_s = std::atof(argv[i + 1]);
    } else if (!std::strcmp(argv[i], "--mix") && !std::strcmp(argv[i + 1], "spiral")) {
      mix = &kSpiralMix;
    } else if (!std::strcmp(argv[i], "--mix") && !std::strcmp(argv[i + 1], "s2")) {
      mix = &kS2Mix;
    } else if (!std::strcmp(argv[i], "--clients")) {
      client_counts.clear();
      for (const char* p = argv[i + 1]; *p != '\0';) {
        char* end = nullptr;
        client_counts.push_back(static_cast<int>(std::strtol(p, &end, 10)));
        p = *end == ',' ? end + 1 : end;
        if (client_counts.back() < 1 || end == p) break;
      }
    } else {
      std::fprintf(stderr,
                   "usage: %s [--server HOST:PORT] [--seconds S] [--runs N] [--clients 1,2,8,32] "
                   "[--mix s2|spiral] [--deadline-s S]\n",
                   argv[0]);
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

  std::string names;
  for (const Query& q : *mix) names += (names.empty() ? "" : ", ") + std::string(q.name);
  std::printf("\n### Throughput (mix of %s; %.0f s per row; %.0f s deadlines)\n\n", names.c_str(),
              seconds, deadline_s);
  std::printf(
      "| clients | plans | failed (by code) | plans/s | p50 ms | p99 ms | max ms | p50 server "
      "queue ms |\n|---|---|---|---|---|---|---|---|\n");
  for (const int clients : client_counts) {
    std::atomic<bool> stop{false};
    std::vector<std::vector<double>> lat(clients), queue(clients);
    std::vector<int> failures(clients, 0);
    std::vector<std::map<int, int>> codes(clients);
    std::vector<std::thread> threads;
    const auto t0 = Clock::now();
    for (int c = 0; c < clients; ++c) {
      threads.emplace_back([&, c] {
        auto own = strata::v1::PlannerService::NewStub(channel);  // own stub, shared channel
        for (std::size_t i = c; !stop.load(std::memory_order_relaxed); ++i) {
          const Outcome o = Plan(*own, Request((*mix)[i % mix->size()]), deadline_s);
          if (stop.load(std::memory_order_relaxed)) break;  // finished after the window
          if (o.status.ok()) {
            lat[c].push_back(o.rpc_s * 1e3);
            queue[c].push_back(o.queue_s * 1e3);
          } else {
            ++failures[c];
            ++codes[c][static_cast<int>(o.status.error_code())];
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
    std::map<int, int> by_code;
    for (int c = 0; c < clients; ++c) {
      all.insert(all.end(), lat[c].begin(), lat[c].end());
      all_queue.insert(all_queue.end(), queue[c].begin(), queue[c].end());
      failed += failures[c];
      for (const auto& [code, n] : codes[c]) by_code[code] += n;
    }
    std::string failed_text = std::to_string(failed);
    for (const auto& [code, n] : by_code) {
      failed_text += " code" + std::to_string(code) + ":" + std::to_string(n);
    }
    std::printf("| %d | %zu | %s | %.1f | %.1f | %.1f | %.1f | %.1f |\n", clients, all.size(),
                failed_text.c_str(), all.size() / window, Quantile(all, 0.5), Quantile(all, 0.99),
                all.empty() ? 0.0 : *std::max_element(all.begin(), all.end()),
                Quantile(all_queue, 0.5));
    std::fflush(stdout);
  }
  return 0;
}
