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

Its robots follow replans (fleet.follows_replans): another robot's plan may have the server
replan one of them to pass first. So it watches the map's schedule (WatchSchedule, in a
background thread) and prints each new trajectory the server gave one of its robots, where a
real dispatcher would send it to the robot. A second phase makes that happen: an urgent order
(r3 must come down from the deck at once, 2 m clear of every robot, while r1 climbs the ramp)
plans r3 with fleet.replan_robots, prints the reservations the server replanned for it, and
checks that the watch saw r1's new trajectory; then it checks the reservations again, each
pair by the larger separation the two asked, and releases them.

The gRPC code comes from proto/ through Debian's protoc and grpc_python_plugin (the build
writes it to build/examples/python/gen; README.md beside this file says how); run it with
Debian's /usr/bin/python3 and PYTHONPATH pointing there:

    PYTHONPATH=build/examples/python/gen examples/python/dispatcher.py --server localhost:50051

Exit codes: 0 every assignment planned, the urgent order planned with r1 replanned (and seen
on the watch), and no two reservations meet; 1 a call failed, a plan failed, the replan did not
come or two reservations meet; 2 bad arguments.
"""
import argparse
import itertools
import math
import sys
import threading
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


# Lines are printed whole under this lock: the schedule's watch prints from a thread of its own.
OUTPUT = threading.Lock()


def say(line):
    with OUTPUT:
        print(line, flush=True)


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
    say(f"{rpc} failed: {error.code().name}: {error.details()} ({reason_of(status)})")
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
    say(f"map {created.id}: {state}, {created.valid_ground_point_count} ground points")
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


CHECK_STEP_S = 0.005
# How far ahead the robots of one phase leave together (the server's clock: keep NTP time), so
# that the plans' timing does not depend on how long each took to make.
DEPARTURE_AHEAD_S = 5

# The urgent order of the second phase (server_fleet_test's replanning case): r1, back on the
# floor, climbs the ramp to the deck; r3, on the deck, must come down under it at once (no
# waiting), 2 m clear of every robot. r1 follows replans, so r3 may have it replanned: r3 goes
# first and r1 waits for it on its way.
URGENT_CLIMB = ("r1", (1.0, 5.25, 0.3), (7.0, 9.25, 3.3))
URGENT_DESCENT = ("r3", (10.0, 9.25, 3.3), (10.0, 9.5, 0.3))
URGENT_SEPARATION_M = 2.0
# The case is made for differential robots, whatever --robot: with the biped's the descent is
# refused (RESERVATION_CONFLICT), r1's replan not clearing its way.
URGENT_PROFILE = "differential"


def seconds_of(timestamp):
    return timestamp.seconds + timestamp.nanos * 1e-9


def departure_ahead():
    departure = timestamp_pb2.Timestamp()
    departure.FromNanoseconds(time.time_ns() + DEPARTURE_AHEAD_S * 1_000_000_000)
    return departure


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


def first_meeting(a, b, separation_m):
    """The first time (every CHECK_STEP_S) two reservations' bodies meet, or None."""
    begin = max(seconds_of(a.start_time), seconds_of(b.start_time))
    end = min(seconds_of(a.expiry_time), seconds_of(b.expiry_time))
    limit = a.body.radius_m + b.body.radius_m + separation_m
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


def pair_separation(a, b):
    """The separation the server keeps between two reservations: the larger of the two they
    ask (Reservation.separation_m)."""
    return max(a.separation_m, b.separation_m)


def check_reservations(traffic, map_id, deadline_s):
    """Lists the map's reservations and checks every pair; returns how many pairs meet."""
    listed = traffic.ListReservations(
        traffic_service_pb2.ListReservationsRequest(map_id=map_id), timeout=deadline_s)
    meetings = 0
    pairs = list(itertools.combinations(listed.reservations, 2))
    for a, b in pairs:
        when = first_meeting(a, b, pair_separation(a, b))
        if when is not None:
            meetings += 1
            say(f"  {a.robot_id} and {b.robot_id} meet {when:.3f} s into their common time")
    say(f"checked {len(pairs)} pairs of {len(listed.reservations)} reservations every "
        f"{CHECK_STEP_S * 1e3:.0f} ms: {meetings} meet")
    return meetings


def release(traffic, map_id, robots, deadline_s):
    for robot in robots:
        traffic.ReleaseReservation(traffic_service_pb2.ReleaseReservationRequest(
            map_id=map_id, robot_id=robot), timeout=deadline_s)
    say(f"released {len(robots)} reservations")


class ScheduleWatch:
    """The map's schedule as it changes (TrafficService.WatchSchedule), read in a background
    thread. A RESERVED change of one of `robots` with replanned_for set is a new trajectory the
    server gave that robot to let another pass first: the robot must follow it from its
    start_time on, so this is where a dispatcher sends it to the robot (here: prints it)."""

    def __init__(self, traffic, map_id, robots, since_revision):
        self._robots = set(robots)
        # The stream begins with every live reservation: those of revision since_revision or
        # older were replanned (if at all) before this dispatcher started, and are not news.
        self._revisions = dict.fromkeys(self._robots, since_revision)
        self._replanned_for = {}  # Robot -> the robot its latest new trajectory let pass.
        self._changed = threading.Condition()
        self._call = traffic.WatchSchedule(traffic_service_pb2.WatchScheduleRequest(map_id=map_id))
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self):
        try:
            for change in self._call:
                self._take(change)
        except grpc.RpcError as error:
            if error.code() != grpc.StatusCode.CANCELLED:  # stop() cancels it.
                say(f"WatchSchedule failed: {error.code().name}: {error.details()}")

    def _take(self, change):
        reservation = change.reservation
        if (change.kind != traffic_service_pb2.ScheduleChange.RESERVED
                or change.robot_id not in self._robots or not reservation.replanned_for
                or reservation.revision <= self._revisions[change.robot_id]):
            return
        say(f"{change.robot_id} replanned to let {reservation.replanned_for} pass: follows the "
            f"new trajectory from {reservation.start_time.ToJsonString()} (revision "
            f"{reservation.revision})")
        with self._changed:
            self._revisions[change.robot_id] = reservation.revision
            self._replanned_for[change.robot_id] = reservation.replanned_for
            self._changed.notify_all()

    def saw_replan(self, robot, replanned_for, timeout_s):
        """Whether the watch has seen `robot` replanned for `replanned_for`, waiting up to
        timeout_s for it (the change may come just after the plan's answer)."""
        with self._changed:
            return self._changed.wait_for(
                lambda: self._replanned_for.get(robot) == replanned_for, timeout_s)

    def stop(self):
        self._call.cancel()
        self._thread.join()


def estimate_and_assign(planner, args):
    """One EstimateCosts over every robot and task, printed; the greedy assignment."""
    robots, tasks = list(ROBOTS), list(TASKS)
    request = planner_service_pb2.EstimateCostsRequest(
        map_id=args.map, profile_name=args.robot,
        starts_m=[vector(ROBOTS[r]) for r in robots], goals_m=[vector(TASKS[t]) for t in tasks])
    costs = planner.EstimateCosts(request, timeout=args.deadline)
    say(f"costs: {len(robots)} robots x {len(tasks)} tasks in "
        f"{costs.stats.total_s * 1e3:.1f} ms")
    for j, task in enumerate(tasks):
        if costs.goals[j].reason:
            say(f"  task {task}: {costs.goals[j].reason}")
    for i, robot in enumerate(robots):
        row = []
        for j, task in enumerate(tasks):
            cell = costs.cells[i * len(tasks) + j]
            row.append(f"{task} {cell.time_s:.1f} s" if cell.reachable
                       else f"{task} {cell.reason}")
        say(f"  {robot}: " + ", ".join(row))
    assigned = assign_greedily(costs, robots, tasks)
    for robot, task, time_s in assigned:
        say(f"assign {robot} -> {task} (estimated {time_s:.1f} s)")
    return assigned


def fleet_plan(args, profile, robot, start, goal, departure, **fleet):
    """A PlanRequest that reserves the robot's trajectory; the robot follows replans."""
    return planner_service_pb2.PlanRequest(
        map_id=args.map, profile_name=profile,
        start=planner_service_pb2.RobotState(position_m=vector(start)),
        goal=planner_service_pb2.RobotState(position_m=vector(goal)),
        departure_time=departure,
        fleet=traffic_service_pb2.FleetOptions(
            robot_id=robot, reserve=True, follows_replans=True, **fleet))


def plan_assignments(planner, args, assigned):
    """Plans the assignments in one PlanBatch, every robot leaving at the same moment; the
    later ones keep out of the earlier ones' way. Returns how many were planned."""
    departure = departure_ahead()
    batch = planner_service_pb2.PlanBatchRequest(requests=[
        fleet_plan(args, args.robot, robot, ROBOTS[robot], TASKS[task], departure)
        for robot, task, _ in assigned])
    planned = 0
    for item in planner.PlanBatch(batch, timeout=args.deadline):
        robot, task, estimate_s = assigned[item.index]
        if item.HasField("response"):
            stats = item.response.stats
            planned += 1
            say(f"plan {robot} -> {task}: {stats.length_m:.2f} m in "
                f"{stats.duration_s:.2f} s (estimated {estimate_s:.2f} s), "
                f"{stats.pieces} MINCO pieces, waits {item.response.wait_s:.1f} s, "
                f"reserved at revision {item.response.reservation.revision}")
        else:
            say(f"plan {robot} -> {task} failed: {item.error.message} "
                f"({reason_of(item.error)})")
    say(f"planned {planned} of {len(assigned)} assignments")
    return planned


def urgent_order(planner, args, watch, held):
    """The second phase: r1 climbs the ramp, then r3's urgent descent may replan it to pass
    first. Adds the robots reserved to `held`; returns whether r1 was replanned for r3 and the
    watch saw it."""
    climber, climb_start, climb_goal = URGENT_CLIMB
    urgent, urgent_start, urgent_goal = URGENT_DESCENT
    departure = departure_ahead()
    climb = planner.Plan(
        fleet_plan(args, URGENT_PROFILE, climber, climb_start, climb_goal, departure),
        timeout=args.deadline)
    held.append(climber)
    say(f"plan {climber} up the ramp: {climb.stats.duration_s:.2f} s, waits "
        f"{climb.wait_s:.1f} s, reserved at revision {climb.reservation.revision}")
    response = planner.Plan(fleet_plan(
        args, URGENT_PROFILE, urgent, urgent_start, urgent_goal, departure, max_wait_s=0,
        separation_m=URGENT_SEPARATION_M, replan_robots=1), timeout=args.deadline)
    held.append(urgent)
    say(f"urgent {urgent} down the ramp: {response.stats.duration_s:.2f} s, waits "
        f"{response.wait_s:.1f} s, reserved at revision {response.reservation.revision}, "
        f"{len(response.replanned)} robot(s) replanned to let it pass first")
    for replanned in response.replanned:
        say(f"  replanned {replanned.robot_id} for {replanned.replanned_for}: its new "
            f"trajectory ({replanned.trajectory.duration_s:.2f} s from "
            f"{replanned.start_time.ToJsonString()}) at revision {replanned.revision}")
    if [r.robot_id for r in response.replanned] != [climber]:
        say(f"{climber} was not replanned for {urgent}")
        return False
    if not watch.saw_replan(climber, urgent, args.deadline):
        say(f"the schedule's watch did not see {climber} replanned for {urgent}")
        return False
    return True


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
            say("the map did not become ACTIVE")
            return 1
    except grpc.RpcError as error:
        return call_error("CreateMap", error)
    try:
        assigned = estimate_and_assign(planner, args)
    except grpc.RpcError as error:
        return call_error("EstimateCosts", error)

    # Watching from the schedule's revision now on, before the first plan: no change of our
    # robots is missed, none from before is taken for news.
    try:
        since = traffic.ListReservations(traffic_service_pb2.ListReservationsRequest(
            map_id=args.map), timeout=args.deadline).revision
    except grpc.RpcError as error:
        return call_error("ListReservations", error)
    watch = ScheduleWatch(traffic, args.map, list(ROBOTS), since)
    try:
        return dispatch(planner, traffic, watch, args, assigned)
    finally:
        watch.stop()


def dispatch(planner, traffic, watch, args, assigned):
    """The two phases, each checked and released; the exit code."""
    try:
        planned = plan_assignments(planner, args, assigned)
    except grpc.RpcError as error:
        return call_error("PlanBatch", error)
    try:
        meetings = check_reservations(traffic, args.map, args.deadline)
        release(traffic, args.map, [robot for robot, _, _ in assigned], args.deadline)
    except grpc.RpcError as error:
        return call_error("TrafficService", error)

    held = []  # The robots the urgent order reserved: released however it ends.
    try:
        replanned = urgent_order(planner, args, watch, held)
        meetings += check_reservations(traffic, args.map, args.deadline)
    except grpc.RpcError as error:
        call_error("urgent order", error)  # Its plans' or its check's call.
        replanned = False
    try:
        release(traffic, args.map, held, args.deadline)
    except grpc.RpcError as error:
        return call_error("ReleaseReservation", error)
    return 0 if assigned and planned == len(assigned) and replanned and meetings == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
