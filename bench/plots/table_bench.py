#!/usr/bin/python3
"""The paper-style table (Table 2) over several `strata-bench` runs, as markdown.

Usage: /usr/bin/python3 bench/plots/table_bench.py RUN_DIR[:NAME] ...
Reads each run's summary.csv and meta.json; prints one row per scene and method.
"""
import csv
import json
import os
import sys

LABELS = {"strata": "Strata", "liu": "Liu-style", "krusi": "Krüsi-style"}


def main():
    print("| scene (points) | method | success | t_a s | time ms median / p95 | "
          "length m median (all / common) | κ_m 3D 1/m median (all / common) | "
          "κ_m x–y 1/m median (all / common) | failures |")
    print("|---|---|---|---|---|---|---|---|---|")
    for run in sys.argv[1:]:
        run_dir, _, name = run.partition(":")
        name = name or os.path.basename(os.path.normpath(run_dir))
        with open(os.path.join(run_dir, "meta.json")) as f:
            meta = json.load(f)
        with open(os.path.join(run_dir, "summary.csv"), newline="") as f:
            rows = list(csv.DictReader(f))
        for i, r in enumerate(rows):
            scene = f"{name} ({meta['points'] / 1000:.0f}k)" if i == 0 else ""
            q, s = int(r["queries"]), int(r["successes"])
            failures = r["failures"]
            if r["method"] == "strata":
                failures += f"; verification violations {r['verify_violations']}"
                if r.get("independent_check"):
                    failures += f"; independent check of {r['independent_check']}"
            print(f"| {scene} | {LABELS[r['method']]} | {s}/{q} ({100.0 * s / q:.1f}%) | "
                  f"{float(r['t_a_s']):.2f} | {1e3 * float(r['time_median_s']):.1f} / "
                  f"{1e3 * float(r['time_p95_s']):.1f} | {float(r['length_median_m']):.1f} / "
                  f"{float(r['common_length_median_m']):.1f} | {float(r['kappa_median']):.3f} / "
                  f"{float(r['common_kappa_median']):.3f} | {float(r['kappa_xy_median']):.3f} / "
                  f"{float(r['common_kappa_xy_median']):.3f} | {failures} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
