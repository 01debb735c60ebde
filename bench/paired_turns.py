#!/usr/bin/env python3
"""Compares two builds' planning benchmarks on a machine whose speed drifts.

Runs BEFORE and AFTER (each a planning_benchmark binary) in turn, TURNS times each, and prints
for every reference query the median over the turns of AFTER's time divided by BEFORE's in
the same turn, with the range. A machine that slows down or speeds up between turns moves
both runs of a turn alike, so the paired ratio holds where each build's own times do not.

    STRATA_MAPS_DIR=../shared/maps bench/paired_turns.py OLD/bench/planning_benchmark \\
        build/bench/planning_benchmark --turns 24

Each run plans the reference queries only (one random pair per map: `planning_benchmark 1 1`).
"""
import argparse
import re
import statistics
import subprocess

# A row of the reference-query table: | name | ok | total ms (median of 5) | ...
ROW = re.compile(r"^\| ((?:s2|sp)_\w+) \| ok \| ([\d.]+) \|")


def query_times(binary):
    """Each planned reference query's median total time [ms] from one run of `binary`."""
    output = subprocess.run([binary, "1", "1"], check=True, capture_output=True, text=True).stdout
    times = {}
    for line in output.splitlines():
        match = ROW.match(line)
        if match and match.group(1) not in times:
            times[match.group(1)] = float(match.group(2))
    return times


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before", help="the planning_benchmark binary to compare against")
    parser.add_argument("after", help="the planning_benchmark binary compared")
    parser.add_argument("--turns", type=int, default=24, help="runs of each, taking turns")
    args = parser.parse_args()
    ratios = {}
    for _ in range(args.turns):
        before, after = query_times(args.before), query_times(args.after)
        for query in before:  # In the benchmark's order.
            if query in after:
                ratios.setdefault(query, []).append(after[query] / before[query])
    print(f"| query | after / before, median of {args.turns} paired ratios (range) |")
    print("|---|---|")
    for query, r in ratios.items():
        print(f"| {query} | {statistics.median(r):.2f} ({min(r):.2f}–{max(r):.2f}) |")


if __name__ == "__main__":
    main()
