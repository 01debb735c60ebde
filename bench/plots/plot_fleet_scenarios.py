#!/usr/bin/python3
"""Draws the fleet scenarios of tests/planner/fleet_plan_test.cpp for docs/design.md §19.

The test writes each scenario's motions when STRATA_FLEET_SCENARIO_DIR is set (robot, t_s,
x, y, z every 50 ms). Each picture has a top view of the paths, with a dot per second and the
time every 5 s, and the horizontal distance between robot B and the others over time against
the limit (2 × 0.3 m radius + 0.1 m separation): B planned alone crosses it, B planned among
the others' reservations does not, or passes at another height. Where A is replanned to let B
pass first, A's committed motion is dashed beside the one it follows.

    bash scripts/install-plot-deps.sh
    mkdir -p /tmp/scenarios
    STRATA_FLEET_SCENARIO_DIR=/tmp/scenarios build/tests/planner/fleet_plan_test
    bench/plots/plot_fleet_scenarios.py /tmp/scenarios docs/img
"""
import csv
import math
import sys
from collections import defaultdict
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

LIMIT_M = 2 * 0.3 + 0.1  # The benchmark's and the test's: radii plus the default separation.
BODY_TOP_M = 0.5  # The differential profile's body height above its ground.
REFERENCE_M = 0.3  # Its reference point above its ground.
TITLES = {
    "head_on_ramp": "Head-on on a one-lane ramp: B waits at the top for A to come up",
    "four_way_crossing": "A crossing: B lets A pass",
    "under_the_deck": "B under the deck while A drives over it: no wait",
    "parked_in_the_way": "C parked in the lane: B drives around it",
    "makes_way_at_goal": "A crosses B's goal later: B arrives, steps aside for A, comes back",
    "replanned_on_its_way": "B may not wait: A, on its way up the ramp, is replanned to wait for B",
}
COLOURS = {"A": "tab:blue", "A committed": "tab:cyan", "C": "tab:gray", "B": "tab:orange",
           "B alone": "tab:red"}
DASHED = ("B alone", "A committed")  # What was planned before, against what is.


def read(path):
    motions = defaultdict(list)
    with open(path) as f:
        for row in csv.DictReader(f):
            motions[row["robot"]].append(
                (float(row["t_s"]), float(row["x"]), float(row["y"]), float(row["z"])))
    return motions


def overlap(a, b):
    """Whether the two bodies' vertical extents overlap (reference point to ground, then up)."""
    bottom_a, bottom_b = a[3] - REFERENCE_M, b[3] - REFERENCE_M
    return bottom_a < bottom_b + BODY_TOP_M and bottom_b < bottom_a + BODY_TOP_M


def draw(name, motions, out_dir):
    fig, (top, dist) = plt.subplots(1, 2, figsize=(12, 4.6),
                                    gridspec_kw={"width_ratios": [1.3, 1]})
    for robot, samples in motions.items():
        xs = [s[1] for s in samples]
        ys = [s[2] for s in samples]
        style = "--" if robot in DASHED else "-"
        top.plot(xs, ys, style, color=COLOURS.get(robot, "k"), label=robot, linewidth=1.5)
        for s in samples[::20]:  # One dot per second.
            top.plot(s[1], s[2], ".", color=COLOURS.get(robot, "k"), markersize=4)
        for s in samples[::100]:  # The time every 5 s.
            top.annotate(f"{s[0]:.0f}", (s[1], s[2]), fontsize=7, color=COLOURS.get(robot, "k"),
                         xytext=(3, 3), textcoords="offset points")
    top.set_aspect("equal")
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.legend(fontsize=8)
    top.set_title("top view (dots every second, labels every 5 s)", fontsize=9)
    others = [r for r in motions if r not in ("B", "B alone")]
    for b in ("B alone", "B"):
        if b not in motions:
            continue
        for other in others:
            pairs = list(zip(motions[b], motions[other]))
            ts = [p[0][0] for p in pairs]
            ds = [math.hypot(p[0][1] - p[1][1], p[0][2] - p[1][2]) for p in pairs]
            shared = [d if overlap(p[0], p[1]) else float("nan") for p, d in zip(pairs, ds)]
            style = "--" if b in DASHED or other in DASHED else "-"
            dist.plot(ts, ds, style, color=COLOURS[b], linewidth=0.8, alpha=0.4)
            dist.plot(ts, shared, style, color=COLOURS[b], linewidth=1.8,
                      label=f"{b} to {other} (bold: same height)")
    dist.axhline(LIMIT_M, color="k", linewidth=0.8)
    dist.text(0, LIMIT_M, " limit 0.7 m", va="bottom", fontsize=8)
    dist.set_ylim(0, 8)
    dist.set_xlabel("time after the departure [s]")
    dist.set_ylabel("horizontal distance [m]")
    dist.legend(fontsize=8)
    fig.suptitle(TITLES.get(name, name), fontsize=11)
    fig.tight_layout()
    fig.savefig(Path(out_dir) / f"fleet_{name}.png", dpi=90)
    plt.close(fig)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    for path in sorted(Path(sys.argv[1]).glob("*.csv")):
        draw(path.stem, read(path), sys.argv[2])
        print(f"fleet_{path.stem}.png")


if __name__ == "__main__":
    main()
