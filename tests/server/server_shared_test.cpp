// Two strata-server replicas on one real etcd (--etcd), as a Kubernetes Deployment runs them:
// a robot's plan reserved on one replica is avoided by a plan on the other, and the
// reservations of a replica killed with SIGKILL stay until their leases end, then let the
// other replica's plans through.
#include <csignal>
#include <span>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "etcd_process.hpp"
#include "reserved_motion.hpp"
#include "rpc/proto_convert.hpp"
#include "rpc/traffic_convert.hpp"
#include "server_fixture.hpp"
#include "strata/fleet/traffic.hpp"
#include "strata/v1/traffic_service.grpc.pb.h"

namespace strata::server::testing {
namespace {

constexpr double kFloorZ = 0.3;  // The demo's ground floor.

v1::PlanRequest FleetPlan(const std::string& robot, double sx, double sy, double gx, double gy,
                          std::int64_t departure_ns, double lease_s) {
  v1::PlanRequest request = PlanRequestFor("demo", sx, sy, kFloorZ, gx, gy, kFloorZ);
  ToProto(departure_ns, request.mutable_departure_time());
  request.mutable_fleet()->set_robot_id(robot);
  request.mutable_fleet()->set_reserve(true);
  request.mutable_fleet()->set_lease_s(lease_s);
  return request;
}

std::unique_ptr<ServerProcess> Replica(const EtcdProcess& etcd) {
  auto server = ServerProcess::Start({"--map-root", TestMapRoot(), "--etcd", etcd.endpoint(),
                                      "--etcd-prefix", "/strata-replicas"});
  if (server != nullptr && !server->WaitServing(std::chrono::seconds(60))) return nullptr;
  return server;
}

grpc::Status PlanOn(const ServerProcess& server, const v1::PlanRequest& request,
                    v1::PlanResponse* response) {
  grpc::ClientContext context;
  SetDeadline(&context, 120);
  return v1::PlannerService::NewStub(server.NewChannel())->Plan(&context, request, response);
}

std::vector<v1::Reservation> ListOn(const ServerProcess& server) {
  grpc::ClientContext context;
  SetDeadline(&context, 10);
  v1::ListReservationsRequest request;
  request.set_map_id("demo");
  v1::ListReservationsResponse response;
  EXPECT_TRUE(v1::TrafficService::NewStub(server.NewChannel())
                  ->ListReservations(&context, request, &response)
                  .ok());
  return {response.reservations().begin(), response.reservations().end()};
}

bool Holds(const ServerProcess& server, const std::string& robot) {
  for (const v1::Reservation& r : ListOn(server)) {
    if (r.robot_id() == robot) return true;
  }
  return false;
}

TEST(ServerSharedTest, ReplicasOnOneEtcdPlanAroundEachOtherAndOutliveAKilledOne) {
  std::unique_ptr<EtcdProcess> etcd = EtcdProcess::Start();
  ASSERT_NE(etcd, nullptr) << "a real etcd is needed (scripts/install-deps.sh installs it)";
  std::unique_ptr<ServerProcess> a = Replica(*etcd);
  std::unique_ptr<ServerProcess> b = Replica(*etcd);
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);

  // Robot "a" on replica A, across the floor, leaving in 2 s, holding its goal 3 s at least.
  const std::int64_t departure = AddSeconds(SystemNowNs(), 2);
  v1::PlanResponse first;
  const grpc::Status planned_a = PlanOn(*a, FleetPlan("a", 3, 5, 13, 10, departure, 3), &first);
  ASSERT_TRUE(planned_a.ok()) << planned_a.error_message();
  ASSERT_TRUE(Eventually([&] { return Holds(*b, "a"); }, std::chrono::seconds(20)));

  // Robot "b" on replica B, across a's way at the same moment: it waits or goes around.
  v1::PlanResponse second;
  // b holds its goal for 10 minutes: it outlives a's reservation, whichever arrives first.
  const grpc::Status planned_b = PlanOn(*b, FleetPlan("b", 3, 10, 13, 5, departure, 600), &second);
  ASSERT_TRUE(planned_b.ok()) << planned_b.error_message();
  const std::vector<ReservedMotion> first_only = {{"a", MotionOf(first.reservation())}};
  EXPECT_FALSE(FirstTrafficConflict(MotionOf(second.reservation()), first_only, SeparationRule{})
                   .has_value())
      << "b's reservation on replica B meets a's, made on replica A";
  ASSERT_TRUE(Eventually([&] { return Holds(*a, "b"); }, std::chrono::seconds(20)));

  // A dies without a word; its robot's reservation stays (B still plans around it) until its
  // lease ends, and etcd then removes it.
  a->Signal(SIGKILL);
  EXPECT_EQ(a->WaitExit(std::chrono::seconds(10)), -1);
  EXPECT_TRUE(Holds(*b, "a"));
  const std::int64_t a_ends = FromProto(first.reservation().expiry_time(), "expiry_time").value();
  ASSERT_TRUE(Eventually([&] { return !Holds(*b, "a"); }, std::chrono::seconds(60)));
  EXPECT_GE(SystemNowNs(), a_ends) << "a's reservation ended before its lease";

  // A new replica reads the schedule as B holds it (its first read of etcd follows its start).
  std::unique_ptr<ServerProcess> c = Replica(*etcd);
  ASSERT_NE(c, nullptr);
  EXPECT_TRUE(Eventually([&] { return Holds(*c, "b"); }, std::chrono::seconds(20)));
  EXPECT_FALSE(Holds(*c, "a"));
}

}  // namespace
}  // namespace strata::server::testing
