// Service figures for docs/benchmarks.md ("Service"): plan latency through gRPC against the
// server's own in-process plan time, and throughput with 1, 2, 8 and 32 concurrent clients.
// Talks to a running strata-server that hosts scene20.2 as "s20" and the spiral as "spiral":
//
//   build/server/strata-server --map-root ../shared/maps
//       --preload spiral=spiral0.3_2.pcd,resolution_m=0.2
//       --preload s20=scene20.2.pcd,resolution_m=0.2
//       --listen 127.0.0.1:50099 --metrics-port -1          (one command line)
//   build/bench/server_benchmark --server 127.0.0.1:50099 [--seconds 5] [--runs 5]
//       [--clients 1,2,8,32] [--mix s2|spiral] [--deadline-s 30] [--batch 1000] [--costs 100]
//
// --batch N: N plans of the mix as one PlanBatch call against the same N as Plan calls from
// 8 parallel clients (plans/s of each, median of --runs; the latency and throughput tables are
// then skipped). --costs N: an N × N EstimateCosts matrix on the spiral, ends drawn from a
// lattice over the map and kept where EstimateCosts finds them reachable (median of --runs).
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

// N plans of `mix` as one PlanBatch call: plans/s (results counted as they stream in).
double BatchThroughput(strata::v1::PlannerService::Stub& stub, const std::vector<Query>& mix,
                       int plans, double deadline_s, int* failed) {
  strata::v1::PlanBatchRequest batch;
  for (int i = 0; i < plans; ++i) *batch.add_requests() = Request(mix[i % mix.size()]);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() +
                       std::chrono::duration_cast<std::chrono::system_clock::duration>(
                           std::chrono::duration<double>(deadline_s)));
  const auto t0 = Clock::now();
  auto reader = stub.PlanBatch(&context, batch);
  strata::v1::PlanBatchResponse item;
  int received = 0;
  while (reader->Read(&item)) {
    ++received;
    *failed += item.has_error();
  }
  const grpc::Status status = reader->Finish();
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  if (!status.ok() || received != plans) {
    std::fprintf(stderr, "PlanBatch: %d of %d results, %s\n", received, plans,
                 status.error_message().c_str());
  }
  return received / seconds;
}

// The same N plans as Plan calls from `clients` threads taking them in turn: plans/s.
double ParallelThroughput(const std::shared_ptr<grpc::Channel>& channel,
                          const std::vector<Query>& mix, int plans, int clients, double deadline_s,
                          int* failed) {
  std::atomic<int> next{0}, errors{0};
  const auto t0 = Clock::now();
  std::vector<std::thread> threads;
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&] {
      auto own = strata::v1::PlannerService::NewStub(channel);
      for (int i = next++; i < plans; i = next++) {
        if (!Plan(*own, Request(mix[i % mix.size()]), deadline_s).status.ok()) ++errors;
      }
    });
  }
  for (std::thread& t : threads) t.join();
  *failed += errors;
  return plans / std::chrono::duration<double>(Clock::now() - t0).count();
}

// `count` reachable ends on the spiral: a lattice over its bounds at three heights per
// level, kept where EstimateCosts from a known ground point finds them reachable.
std::vector<strata::v1::Vector3> SpiralEnds(strata::v1::PlannerService::Stub& stub, int count) {
  strata::v1::EstimateCostsRequest probe;
  probe.set_map_id("spiral");
  probe.set_profile_name("differential");
  auto* origin = probe.add_starts_m();
  origin->set_x(-30);
  origin->set_y(-2);
  origin->set_z(1.5);
  for (double z = 1.5; z < 22; z += 4) {
    for (double x = -58; x < 16; x += 3.1) {
      for (double y = -30; y < 6; y += 2.9) {
        auto* p = probe.add_goals_m();
        p->set_x(x);
        p->set_y(y);
        p->set_z(z);
      }
    }
  }
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  strata::v1::EstimateCostsResponse response;
  const grpc::Status status = stub.EstimateCosts(&context, probe, &response);
  std::vector<strata::v1::Vector3> ends;
  if (!status.ok()) {
    std::fprintf(stderr, "EstimateCosts probe: %s\n", status.error_message().c_str());
    return ends;
  }
  for (int j = 0; j < response.cells_size(); ++j) {
    if (response.cells(j).reachable()) ends.push_back(probe.goals_m(j));
  }
  // Spread over the lattice rather than its first rows.
  std::vector<strata::v1::Vector3> picked;
  for (int k = 0; k < count && !ends.empty(); ++k) {
    picked.push_back(ends[(static_cast<std::size_t>(k) * 7919) % ends.size()]);
  }
  return picked;
}

}  // namespace

int main(int argc, char** argv) {
  std::string address = "127.0.0.1:50099";
  double seconds = 5;
  int runs = 5;
  double deadline_s = 30;
  std::vector<int> client_counts = {1, 2, 8, 32};
  int batch_plans = 0, cost_size = 0;
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
    } else if (!std::strcmp(argv[i], "--batch")) {
      batch_plans = std::atoi(argv[i + 1]);
    } else if (!std::strcmp(argv[i], "--costs")) {
      cost_size = std::atoi(argv[i + 1]);
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
                   "[--mix s2|spiral] [--deadline-s S] [--batch N] [--costs N]\n",
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

  if (batch_plans > 0 || cost_size > 0) {
    if (batch_plans > 0) {
      std::string names;
      for (const Query& q : *mix) names += (names.empty() ? "" : ", ") + std::string(q.name);
      std::printf("### %d plans (mix of %s): one PlanBatch against 8 parallel Plan clients\n\n",
                  batch_plans, names.c_str());
      std::printf(
          "| run | PlanBatch plans/s | Plan × 8 clients plans/s | ratio |\n|---|---|---|---|\n");
      std::vector<double> batch_rate, parallel_rate, ratio;
      int failed = 0;
      for (int run = 0; run < runs; ++run) {
        // Alternated, so a drift of the machine touches both alike.
        batch_rate.push_back(BatchThroughput(*stub, *mix, batch_plans, deadline_s * 10, &failed));
        parallel_rate.push_back(
            ParallelThroughput(channel, *mix, batch_plans, 8, deadline_s, &failed));
        ratio.push_back(batch_rate.back() / parallel_rate.back());
        std::printf("| %d | %.1f | %.1f | %.3f |\n", run + 1, batch_rate.back(),
                    parallel_rate.back(), ratio.back());
        std::fflush(stdout);
      }
      std::printf("| median | %.1f | %.1f | %.3f |\n\nfailed plans: %d\n\n", Median(batch_rate),
                  Median(parallel_rate), Median(ratio), failed);
    }
    if (cost_size > 0) {
      const std::vector<strata::v1::Vector3> ends = SpiralEnds(*stub, 2 * cost_size);
      if (ends.size() < static_cast<std::size_t>(2 * cost_size)) return 1;
      strata::v1::EstimateCostsRequest request;
      request.set_map_id("spiral");
      request.set_profile_name("differential");
      for (int k = 0; k < cost_size; ++k) {
        *request.add_starts_m() = ends[static_cast<std::size_t>(k)];
        *request.add_goals_m() = ends[static_cast<std::size_t>(cost_size + k)];
      }
      std::vector<double> rpc_ms, total_ms, prepare_ms;
      int reachable = 0, slots = 0;
      for (int run = 0; run < runs; ++run) {
        grpc::ClientContext context;
        context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
        strata::v1::EstimateCostsResponse response;
        const auto t0 = Clock::now();
        const grpc::Status status = stub->EstimateCosts(&context, request, &response);
        rpc_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        if (!status.ok()) {
          std::fprintf(stderr, "EstimateCosts: %s\n", status.error_message().c_str());
          return 1;
        }
        total_ms.push_back(response.stats().total_s() * 1e3);
        prepare_ms.push_back(response.stats().prepare_s() * 1e3);
        reachable = 0;
        for (const auto& cell : response.cells()) reachable += cell.reachable();
        slots = response.stats().slots_used();
      }
      std::printf(
          "### EstimateCosts %d × %d on the spiral (median of %d)\n\n| RPC ms | server total ms | "
          "prepare ms | slots used | reachable cells |\n|---|---|---|---|---|\n| %.1f | %.1f | "
          "%.1f | %d | %d |\n",
          cost_size, cost_size, runs, Median(rpc_ms), Median(total_ms), Median(prepare_ms), slots,
          reachable);
    }
    return 0;
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
