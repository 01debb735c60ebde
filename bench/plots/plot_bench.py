#!/usr/bin/python3
"""Plots of `strata-bench` runs (paper Table 2 and its trajectory figure).

For every run directory (results.csv, paths.csv, cloud.csv, meta.json as the bench command
writes them) it draws
  <name>_paths.png  top and side view of the three methods' paths for a few queries that every
                    method solved, over the map's points (coloured by height);
  <name>_dist.png   distributions of planning time and mean curvature κ_m (of the x–y
                    projection) per method over all successful queries, length relative to
                    Strata's on the queries every method solved, and the success rate;
  bench_overview.png (two runs or more) success, t_a, median length ratio and κ_m per scene.

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
    """Up to `count` dumped queries, spread from long to short: those every method solved
    first, then (where too few) those most methods solved, down to one method's."""
    solved = {}
    for row in results:
        q = int(row["query"])
        if row["success"] == "1" and (row["method"], q) in paths:
            solved.setdefault(q, {})[row["method"]] = float(row["length_m"])
    ranked = sorted(solved, key=lambda q: (-len(solved[q]), -max(solved[q].values())))
    full = [q for q in ranked if len(solved[q]) == len(methods)]
    if len(full) > count:
        full.sort(key=lambda q: -max(solved[q].values()))
        return [full[int(i * (len(full) - 1) / max(1, count - 1))] for i in range(count)]
    rest = [q for q in ranked if q not in full]
    return full + rest[:count - len(full)]


def plot_paths(name, cloud, results, paths, methods, out_dir, count):
    queries = shown_queries(results, paths, methods, count)
    fig, (top, side) = plt.subplots(2, 1, figsize=(10, 11), gridspec_kw={"height_ratios": [3, 1.4]})
    z = cloud[:, 2]
    order = np.argsort(z)  # Higher points drawn last, so upper levels stay visible from above.
    top.scatter(cloud[order, 0], cloud[order, 1], c=z[order], s=0.3, cmap="Greys", alpha=0.6,
                linewidths=0, rasterized=True)
    side.scatter(cloud[:, 0], cloud[:, 2], c="0.75", s=0.2, alpha=0.5, linewidths=0, rasterized=True)
    styles = ["-", "--", "-.", ":"]
    labelled = set()
    for k, q in enumerate(queries):
        for m in methods:
            if (m, q) not in paths:
                continue  # This method did not solve the query.
            p = paths[(m, q)]
            label = LABELS[m] if m not in labelled else None
            labelled.add(m)
            top.plot(p[:, 0], p[:, 1], styles[k % 4], color=COLOURS[m], lw=1.6, label=label)
            side.plot(p[:, 0], p[:, 2], styles[k % 4], color=COLOURS[m], lw=1.2)
        first = next(paths[(m, q)] for m in methods if (m, q) in paths)
        start, goal = first[0], first[-1]
        top.plot(*start[:2], "o", color="k", ms=6)
        top.plot(*goal[:2], "*", color="k", ms=10)
        top.annotate(f"q{q}", start[:2], textcoords="offset points", xytext=(4, 4), fontsize=8)
    top.set_aspect("equal")
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    missing = sum(1 for q in queries for m in methods if (m, q) not in paths)
    top.set_title(f"{name}: top view of {len(queries)} queries (o start, * goal; line style = "
                  f"query){'; a missing colour = that method failed' if missing else ''}",
                  fontsize=10)
    top.legend(loc="upper right", fontsize=9)
    side.set_xlabel("x [m]")
    side.set_ylabel("z [m]")
    side.set_title("side view (x, z) of the same paths")
    return save_figure(fig, out_dir, f"{name}_paths.png", dpi=95)


def save_figure(fig, out_dir, filename, dpi):
    """Lays out, writes and closes `fig`; returns the PNG's path."""
    fig.tight_layout()
    path = os.path.join(out_dir, filename)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def common_queries(results, methods):
    solved = {}
    for r in results:
        if r["success"] == "1":
            solved.setdefault(r["query"], {})[r["method"]] = r
    return {q: m for q, m in solved.items() if all(x in m for x in methods)}


def plot_distributions(name, results, methods, out_dir):
    fig, axes = plt.subplots(1, 4, figsize=(15, 4.2))
    for ax, (key, label) in zip(axes[:2], [("plan_s", "planning time per query [ms]"),
                                           ("kappa_xy_m", "κ_m of the x–y projection [1/m]")]):
        scale = 1e3 if key == "plan_s" else 1.0
        data = [[max(float(r[key]) * scale, 1e-4) for r in results
                 if r["method"] == m and r["success"] == "1"] or [np.nan] for m in methods]
        parts = ax.boxplot(data, labels=[LABELS[m] for m in methods], showfliers=True,
                           flierprops={"markersize": 2}, patch_artist=True)
        for patch, m in zip(parts["boxes"], methods):
            patch.set_facecolor(COLOURS[m])
            patch.set_alpha(0.5)
        ax.set_yscale("log")
        ax.set_title(label + "\n(all successful queries)", fontsize=10)
        ax.tick_params(axis="x", labelsize=8)
    # Length like for like: each method's length over Strata's on the queries all solved.
    common = common_queries(results, methods)
    ax = axes[2]
    if "strata" in methods and common:
        others = [m for m in methods if m != "strata"]
        data = [[float(c[m]["length_m"]) / float(c["strata"]["length_m"]) for c in common.values()
                 if float(c["strata"]["length_m"]) > 0] for m in others]
        parts = ax.boxplot(data, labels=[LABELS[m] for m in others], patch_artist=True,
                           flierprops={"markersize": 2})
        for patch, m in zip(parts["boxes"], others):
            patch.set_facecolor(COLOURS[m])
            patch.set_alpha(0.5)
        ax.axhline(1.0, color=COLOURS["strata"], lw=1, ls="--", label="Strata")
        ax.legend(fontsize=8)
    ax.set_title(f"length / Strata's length\n({len(common)} queries every method solved)",
                 fontsize=10)
    ax.tick_params(axis="x", labelsize=8)
    rates = []
    for m in methods:
        rows = [r for r in results if r["method"] == m]
        rates.append(100.0 * sum(r["success"] == "1" for r in rows) / max(1, len(rows)))
    axes[3].bar([LABELS[m] for m in methods], rates, color=[COLOURS[m] for m in methods], alpha=0.7)
    for i, v in enumerate(rates):
        axes[3].text(i, v + 1, f"{v:.0f}%", ha="center", fontsize=9)
    axes[3].set_ylim(0, 105)
    axes[3].set_title("success rate [%]", fontsize=10)
    axes[3].tick_params(axis="x", labelsize=8)
    n = len({r["query"] for r in results})
    fig.suptitle(f"{name}: {n} random start/goal pairs")
    return save_figure(fig, out_dir, f"{name}_dist.png", dpi=100)


def plot_overview(runs, out_dir):
    """One figure over all runs: success, t_a, length ratio and κ_m per scene and method."""
    names = [name for name, _ in runs]
    fig, axes = plt.subplots(4, 1, figsize=(max(8, 1.3 * len(names)), 12), sharex=True)
    width = 0.27
    x = np.arange(len(names))
    for k, m in enumerate(METHODS):
        rate, t_a, ratio, kappa = [], [], [], []
        for name, (results, meta) in runs:
            rows = [r for r in results if r["method"] == m]
            # A method a run left out (--methods) gets no bar, not a 0% one.
            rate.append(100.0 * sum(r["success"] == "1" for r in rows) / len(rows) if rows else np.nan)
            t_a.append(meta["assessment"].get(m, {}).get("t_a_s", np.nan))
            common = common_queries(results, [x for x in METHODS if any(r["method"] == x for r in results)])
            ratio.append(np.median([float(c[m]["length_m"]) / float(c["strata"]["length_m"])
                                    for c in common.values()
                                    if m in c and "strata" in c
                                    and float(c["strata"]["length_m"]) > 0]) if common else np.nan)
            ks = [float(r["kappa_xy_m"]) for r in rows if r["success"] == "1"]
            kappa.append(np.median(ks) if ks else np.nan)
        for ax, values in zip(axes, [rate, t_a, ratio, kappa]):
            ax.bar(x + (k - 1) * width, values, width, color=COLOURS[m], alpha=0.75, label=LABELS[m])
    axes[0].set_ylabel("success [%]")
    axes[1].set_ylabel("t_a [s]")
    axes[1].set_yscale("log")
    axes[2].set_ylabel("median length /\nStrata's (common)")
    axes[2].axhline(1.0, color="k", lw=0.8)
    axes[2].set_ylim(0.8, None)
    axes[3].set_ylabel("median κ_m, x–y [1/m]")
    axes[3].set_yscale("log")
    axes[0].legend(ncol=3, fontsize=9)
    axes[3].set_xticks(x)
    axes[3].set_xticklabels(names, rotation=30, ha="right")
    fig.suptitle("Strata vs the Liu-style and Krüsi-style baselines, every scene")
    return save_figure(fig, out_dir, "bench_overview.png", dpi=100)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs", nargs="+", help="RUN_DIR or RUN_DIR:NAME")
    parser.add_argument("--out", required=True, help="directory for the PNGs")
    parser.add_argument("--queries", type=int, default=3, help="queries drawn per scene")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    overview = []
    for run in args.runs:
        run_dir, _, name = run.partition(":")
        name = name or os.path.basename(os.path.normpath(run_dir))
        cloud, results, paths, meta = load_run(run_dir)
        methods = [m for m in METHODS if any(r["method"] == m for r in results)]
        print(plot_paths(name, cloud, results, paths, methods, args.out, args.queries))
        print(plot_distributions(name, results, methods, args.out))
        overview.append((name, (results, meta)))
    if len(overview) > 1:
        print(plot_overview(overview, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
