#!/usr/bin/python3
"""A fleet dispatcher on strata-server, in Python.

It creates a map from a built-in scene (the two-level hall: a floor, a ramp and a deck), asks
for the travel times from every robot to every task in one EstimateCosts call, assigns tasks
to robots greedily (the cheapest reachable pair first, each robot and task once), and plans
the assignments in one PlanBatch call, printing each plan as it arrives.

The gRPC code comes from proto/ through Debian's protoc and grpc_python_plugin (the build
writes it to build/examples/python/gen; README.md beside this file says how); run it with
Debian's /usr/bin/python3 and PYTHONPATH pointing there:

    PYTHONPATH=build/examples/python/gen examples/python/dispatcher.py --server localhost:50051

Exit codes: 0 every assignment planned; 1 a call failed or a plan failed; 2 bad arguments.
"""
import argparse
import sys

import grpc
from google.rpc import error_details_pb2, status_pb2

from strata.v1 import common_pb2, map_service_pb2, map_service_pb2_grpc
from strata.v1 import planner_service_pb2, planner_service_pb2_grpc

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
    batch = planner_service_pb2.PlanBatchRequest(requests=[
        planner_service_pb2.PlanRequest(
            map_id=args.map, profile_name=args.robot,
            start=planner_service_pb2.RobotState(position_m=vector(ROBOTS[robot])),
            goal=planner_service_pb2.RobotState(position_m=vector(TASKS[task])))
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
                      f"{stats.pieces} MINCO pieces")
            else:
                print(f"plan {robot} -> {task} failed: {item.error.message} "
                      f"({reason_of(item.error)})")
    except grpc.RpcError as error:
        return call_error("PlanBatch", error)
    print(f"planned {planned} of {len(assigned)} assignments")
    return 0 if assigned and planned == len(assigned) else 1


if __name__ == "__main__":
    sys.exit(main())
