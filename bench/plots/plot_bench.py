#!/usr/bin/python3
"""Plots of `strata-offline bench` runs (issue 5, paper Table 2 and its trajectory figure).

For every run directory (results.csv, paths.csv, cloud.csv, meta.json as the bench command
writes them) it draws
  <name>_paths.png  top and side view of the three methods' paths for a few queries that every
                    method solved, over the map's points (coloured by height);
  <name>_dist.png   distributions of planning time, length and mean curvature κ_m per method
                    over all successful queries, and the success rate.

Usage: /usr/bin/python3 bench/plots/plot_bench.py --out docs/img RUN_DIR[:NAME] ...
Needs Debian's python3-matplotlib and python3-numpy (scripts/install-plot-deps.sh).
"""
import argparse
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

METHODS = ["strata", "liu", "krusi"]
LABELS = {"strata": "Strata (ours)", "liu": "Liu-style", "krusi": "Krüsi-style"}
COLOURS = {"strata": "#1f5fbf", "liu": "#e07b00", "krusi": "#2a9d3a"}


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def load_run(run_dir):
    cloud = np.loadtxt(os.path.join(run_dir, "cloud.csv"), delimiter=",", skiprows=1, ndmin=2)
    results = read_rows(os.path.join(run_dir, "results.csv"))
    paths = {}
    for row in read_rows(os.path.join(run_dir, "paths.csv")):
        key = (row["method"], int(row["query"]))
        paths.setdefault(key, []).append((float(row["x"]), float(row["y"]), float(row["z"])))
    with open(os.path.join(run_dir, "meta.json")) as f:
        meta = json.load(f)
    return cloud, results, {k: np.array(v) for k, v in paths.items()}, meta


def shown_queries(results, paths, methods, count):
    """Queries every method solved and dumped, longest Strata paths first (they show most)."""
    solved = {}
    for row in results:
        if row["success"] == "1":
            solved.setdefault(int(row["query"]), {})[row["method"]] = float(row["length_m"])
    both = [q for q, m in solved.items()
            if all(x in m for x in methods) and all((x, q) in paths for x in methods)]
    both.sort(key=lambda q: -solved[q][methods[0]])
    # Spread the choice over short and long queries.
    if len(both) > count:
        both = [both[int(i * (len(both) - 1) / (count - 1))] for i in range(count)] if count > 1 else both[:1]
    return both


def plot_paths(name, cloud, results, paths, methods, out_dir, count):
    queries = shown_queries(results, paths, methods, count)
    fig, (top, side) = plt.subplots(2, 1, figsize=(10, 11), gridspec_kw={"height_ratios": [3, 1.4]})
    z = cloud[:, 2]
    order = np.argsort(z)  # Higher points drawn last, so upper levels stay visible from above.
    top.scatter(cloud[order, 0], cloud[order, 1], c=z[order], s=0.3, cmap="Greys", alpha=0.6,
                linewidths=0, rasterized=True)
    side.scatter(cloud[:, 0], cloud[:, 2], c="0.75", s=0.2, alpha=0.5, linewidths=0, rasterized=True)
    styles = ["-", "--", "-.", ":"]
    for k, q in enumerate(queries):
        for m in methods:
            p = paths[(m, q)]
            label = LABELS[m] if k == 0 else None
            top.plot(p[:, 0], p[:, 1], styles[k % 4], color=COLOURS[m], lw=1.6, label=label)
            side.plot(p[:, 0], p[:, 2], styles[k % 4], color=COLOURS[m], lw=1.2)
        start = paths[(methods[0], q)][0]
        goal = paths[(methods[0], q)][-1]
        top.plot(*start[:2], "o", color="k", ms=6)
        top.plot(*goal[:2], "*", color="k", ms=10)
        top.annotate(f"q{q}", start[:2], textcoords="offset points", xytext=(4, 4), fontsize=8)
    top.set_aspect("equal")
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.set_title(f"{name}: top view, {len(queries)} queries every method solved "
                  "(o start, * goal; line style = query)")
    top.legend(loc="upper right", fontsize=9)
    side.set_xlabel("x [m]")
    side.set_ylabel("z [m]")
    side.set_title("side view (x, z) of the same paths")
    fig.tight_layout()
    path = os.path.join(out_dir, f"{name}_paths.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_distributions(name, results, methods, out_dir):
    fig, axes = plt.subplots(1, 4, figsize=(15, 4.2))
    metrics = [("plan_s", "planning time [ms]", 1e3, True),
               ("length_m", "length [m]", 1.0, False),
               ("kappa_m", "κ_m [1/m]", 1.0, True)]
    for ax, (key, label, scale, log) in zip(axes, metrics):
        data = [[float(r[key]) * scale for r in results
                 if r["method"] == m and r["success"] == "1"] for m in methods]
        data = [d if d else [np.nan] for d in data]
        if log:
            data = [[max(v, 1e-4) for v in d] for d in data]
        parts = ax.boxplot(data, labels=[LABELS[m] for m in methods], showfliers=True,
                           flierprops={"markersize": 2}, patch_artist=True)
        for patch, m in zip(parts["boxes"], methods):
            patch.set_facecolor(COLOURS[m])
            patch.set_alpha(0.5)
        if log:
            ax.set_yscale("log")
        ax.set_title(label)
        ax.tick_params(axis="x", labelsize=8)
    rates = []
    for m in methods:
        rows = [r for r in results if r["method"] == m]
        rates.append(100.0 * sum(r["success"] == "1" for r in rows) / max(1, len(rows)))
    axes[3].bar([LABELS[m] for m in methods], rates, color=[COLOURS[m] for m in methods], alpha=0.7)
    axes[3].set_ylim(0, 100)
    axes[3].set_title("success rate [%]")
    axes[3].tick_params(axis="x", labelsize=8)
    n = len({r["query"] for r in results})
    fig.suptitle(f"{name}: {n} random start/goal pairs (successful queries only in the boxes)")
    fig.tight_layout()
    path = os.path.join(out_dir, f"{name}_dist.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", nargs="+", help="RUN_DIR or RUN_DIR:NAME")
    parser.add_argument("--out", required=True, help="directory for the PNGs")
    parser.add_argument("--queries", type=int, default=3, help="queries drawn per scene")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    for run in args.runs:
        run_dir, _, name = run.partition(":")
        name = name or os.path.basename(os.path.normpath(run_dir))
        cloud, results, paths, meta = load_run(run_dir)
        methods = [m for m in METHODS if any(r["method"] == m for r in results)]
        print(plot_paths(name, cloud, results, paths, methods, args.out, args.queries))
        print(plot_distributions(name, results, methods, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
