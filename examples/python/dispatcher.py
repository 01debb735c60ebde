#!/usr/bin/python3
"""A fleet dispatcher on strata-server, in Python.

It creates a map from a built-in scene (the two-level hall: a floor, a ramp and a deck), asks
for the travel times from every robot to every task in one EstimateCosts call, assigns tasks
to robots greedily (the cheapest reachable pair first, each robot and task once), and plans
the assignments in one PlanBatch call, printing each plan as it arrives. The robots share the
hall: each plan is made among the others' reservations and reserves its own (a fleet block,
every robot leaving at the same moment), so a robot waits or goes around where another passes.
Then it lists the reservations and checks them with a sampled conflict check of its own (every
5 ms, the bodies' cylinders as the API defines them), and releases them.

The gRPC code comes from proto/ through Debian's protoc and grpc_python_plugin (the build
writes it to build/examples/python/gen; README.md beside this file says how); run it with
Debian's /usr/bin/python3 and PYTHONPATH pointing there:

    PYTHONPATH=build/examples/python/gen examples/python/dispatcher.py --server localhost:50051

Exit codes: 0 every assignment planned and no two reservations meet; 1 a call failed, a plan
failed or two reservations meet; 2 bad arguments.
"""
import argparse
import itertools
import math
import sys
import time

import grpc
from google.protobuf import timestamp_pb2
from google.rpc import error_details_pb2, status_pb2

from strata.v1 import common_pb2, map_service_pb2, map_service_pb2_grpc
from strata.v1 import planner_service_pb2, planner_service_pb2_grpc
from strata.v1 import traffic_service_pb2, traffic_service_pb2_grpc

# Robots and tasks in the two-level hall (x, y, z in metres; z picks the level: about 0.3 m
# above the floor at z = 0, or above the deck at z = 3). One task, on the roof of nothing, lies
# off the map: the estimate says so and the dispatcher leaves it out.
ROBOTS = {
    "r1": (2.0, 2.0, 0.3),
    "r2": (8.0, 5.25, 0.3),
    "r3": (12.0, 10.0, 3.3),
}
TASKS = {
    "pick-deck": (10.0, 10.0, 3.3),
    "drop-floor": (12.0, 9.0, 0.3),
    "charge": (3.0, 9.0, 0.3),
    "nowhere": (60.0, 60.0, 0.3),
}


def vector(xyz):
    return common_pb2.Vector3(x=xyz[0], y=xyz[1], z=xyz[2])


def reason_of(status):
    """The ErrorInfo reason in a google.rpc.Status (the error of a PlanBatch item)."""
    for detail in status.details:
        info = error_details_pb2.ErrorInfo()
        if detail.Unpack(info):
            return info.reason
    return ""


def call_error(rpc, error):
    """Reports a failed call with its ErrorInfo reason, as the server packs it."""
    status = status_pb2.Status()
    for key, value in error.trailing_metadata() or ():
        if key == "grpc-status-details-bin":
            status.ParseFromString(value)
    print(f"{rpc} failed: {error.code().name}: {error.details()} ({reason_of(status)})")
    return 1


def ensure_map(maps, map_id, deadline_s):
    """Creates the map from the two-level hall scene and waits until it is ACTIVE."""
    request = map_service_pb2.CreateMapRequest(
        map_id=map_id, scene=map_service_pb2.SceneSource(name="two_level_ramp"), wait=True)
    try:
        created = maps.CreateMap(request, timeout=deadline_s)
    except grpc.RpcError as error:
        if error.code() != grpc.StatusCode.ALREADY_EXISTS:
            raise
        created = maps.GetMap(map_service_pb2.GetMapRequest(map_id=map_id), timeout=deadline_s)
    state = map_service_pb2.MapState.Name(created.state)
    print(f"map {created.id}: {state}, {created.valid_ground_point_count} ground points")
    return created.state == map_service_pb2.MAP_STATE_ACTIVE


def assign_greedily(costs, robots, tasks):
    """Pairs of (robot, task, time_s): the cheapest reachable pair first, each once."""
    cells = []
    for i, robot in enumerate(robots):
        for j, task in enumerate(tasks):
            cell = costs.cells[i * len(tasks) + j]
            if cell.reachable:
                cells.append((cell.time_s, robot, task))
    assigned, busy_robots, done_tasks = [], set(), set()
    for time_s, robot, task in sorted(cells):
        if robot in busy_robots or task in done_tasks:
            continue
        assigned.append((robot, task, time_s))
        busy_robots.add(robot)
        done_tasks.add(task)
    return assigned


# The server's default free distance between two bodies (strata-server --separation-m).
SEPARATION_M = 0.1
CHECK_STEP_S = 0.005


def seconds_of(timestamp):
    return timestamp.seconds + timestamp.nanos * 1e-9


def state_at(trajectory, t):
    """The trajectory's axes at time t from its start, held before the start and after the end."""
    t = min(max(t, 0.0), trajectory.duration_s)
    last = len(trajectory.pieces) - 1
    for i, piece in enumerate(trajectory.pieces):
        if t <= piece.duration_s or i == last:
            local = min(t, piece.duration_s)
            return [sum(c * local ** k for k, c in enumerate(axis.coefficients))
                    for axis in piece.axes]
        t -= piece.duration_s
    return []


def first_meeting(a, b):
    """The first time (every CHECK_STEP_S) two reservations' bodies meet, or None."""
    begin = max(seconds_of(a.start_time), seconds_of(b.start_time))
    end = min(seconds_of(a.expiry_time), seconds_of(b.expiry_time))
    limit = a.body.radius_m + b.body.radius_m + SEPARATION_M
    steps = int(max(0.0, end - begin) / CHECK_STEP_S)
    for k in range(steps + 1):
        now = begin + k * CHECK_STEP_S
        pa = state_at(a.trajectory, now - seconds_of(a.start_time))
        pb = state_at(b.trajectory, now - seconds_of(b.start_time))
        bottom_a = pa[2] - a.body.reference_height_m
        bottom_b = pb[2] - b.body.reference_height_m
        top_a = bottom_a + (pa[3] if len(pa) > 3 else a.body.height_m)
        top_b = bottom_b + (pb[3] if len(pb) > 3 else b.body.height_m)
        if (math.hypot(pa[0] - pb[0], pa[1] - pb[1]) < limit and top_a > bottom_b
                and top_b > bottom_a):
            return now - begin
    return None


def check_reservations(traffic, map_id, deadline_s):
    """Lists the map's reservations and checks every pair; returns how many pairs meet."""
    listed = traffic.ListReservations(
        traffic_service_pb2.ListReservationsRequest(map_id=map_id), timeout=deadline_s)
    meetings = 0
    pairs = list(itertools.combinations(listed.reservations, 2))
    for a, b in pairs:
        when = first_meeting(a, b)
        if when is not None:
            meetings += 1
            print(f"  {a.robot_id} and {b.robot_id} meet {when:.3f} s into their common time")
    print(f"checked {len(pairs)} pairs of {len(listed.reservations)} reservations every "
          f"{CHECK_STEP_S * 1e3:.0f} ms: {meetings} meet")
    return meetings


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--server", default="localhost:50051", help="strata-server HOST:PORT")
    parser.add_argument("--map", default="python-dispatch", help="id of the map to create")
    parser.add_argument("--robot", default="differential", help="robot profile name")
    parser.add_argument("--deadline", type=float, default=60.0, help="deadline of each call [s]")
    args = parser.parse_args()

    channel = grpc.insecure_channel(args.server)
    maps = map_service_pb2_grpc.MapServiceStub(channel)
    planner = planner_service_pb2_grpc.PlannerServiceStub(channel)
    traffic = traffic_service_pb2_grpc.TrafficServiceStub(channel)
    try:
        if not ensure_map(maps, args.map, args.deadline):
            print("the map did not become ACTIVE")
            return 1
    except grpc.RpcError as error:
        return call_error("CreateMap", error)

    robots, tasks = list(ROBOTS), list(TASKS)
    request = planner_service_pb2.EstimateCostsRequest(
        map_id=args.map, profile_name=args.robot,
        starts_m=[vector(ROBOTS[r]) for r in robots], goals_m=[vector(TASKS[t]) for t in tasks])
    try:
        costs = planner.EstimateCosts(request, timeout=args.deadline)
    except grpc.RpcError as error:
        return call_error("EstimateCosts", error)
    print(f"costs: {len(robots)} robots x {len(tasks)} tasks in "
          f"{costs.stats.total_s * 1e3:.1f} ms")
    for j, task in enumerate(tasks):
        if costs.goals[j].reason:
            print(f"  task {task}: {costs.goals[j].reason}")
    for i, robot in enumerate(robots):
        row = []
        for j, task in enumerate(tasks):
            cell = costs.cells[i * len(tasks) + j]
            row.append(f"{task} {cell.time_s:.1f} s" if cell.reachable
                       else f"{task} {cell.reason}")
        print(f"  {robot}: " + ", ".join(row))

    assigned = assign_greedily(costs, robots, tasks)
    for robot, task, time_s in assigned:
        print(f"assign {robot} -> {task} (estimated {time_s:.1f} s)")
    # Every robot leaves at the same moment, a few seconds from now (the server's clock: keep
    # NTP time), and reserves its trajectory; the later ones keep out of the earlier ones' way.
    departure = timestamp_pb2.Timestamp()
    departure.FromNanoseconds(time.time_ns() + 5_000_000_000)
    batch = planner_service_pb2.PlanBatchRequest(requests=[
        planner_service_pb2.PlanRequest(
            map_id=args.map, profile_name=args.robot,
            start=planner_service_pb2.RobotState(position_m=vector(ROBOTS[robot])),
            goal=planner_service_pb2.RobotState(position_m=vector(TASKS[task])),
            departure_time=departure,
            fleet=traffic_service_pb2.FleetOptions(robot_id=robot, reserve=True))
        for robot, task, _ in assigned])
    planned = 0
    try:
        for item in planner.PlanBatch(batch, timeout=args.deadline):
            robot, task, estimate_s = assigned[item.index]
            if item.HasField("response"):
                stats = item.response.stats
                planned += 1
                print(f"plan {robot} -> {task}: {stats.length_m:.2f} m in "
                      f"{stats.duration_s:.2f} s (estimated {estimate_s:.2f} s), "
                      f"{stats.pieces} MINCO pieces, waits {item.response.wait_s:.1f} s, "
                      f"reserved at revision {item.response.reservation.revision}")
            else:
                print(f"plan {robot} -> {task} failed: {item.error.message} "
                      f"({reason_of(item.error)})")
    except grpc.RpcError as error:
        return call_error("PlanBatch", error)
    print(f"planned {planned} of {len(assigned)} assignments")
    try:
        meetings = check_reservations(traffic, args.map, args.deadline)
        for robot, _, _ in assigned:
            traffic.ReleaseReservation(traffic_service_pb2.ReleaseReservationRequest(
                map_id=args.map, robot_id=robot), timeout=args.deadline)
    except grpc.RpcError as error:
        return call_error("TrafficService", error)
    print(f"released {len(assigned)} reservations")
    return 0 if assigned and planned == len(assigned) and meetings == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
