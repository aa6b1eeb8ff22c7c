#!/usr/bin/python3
"""Paper 003's tables from sweeps of worlds/ultrasonic/experiments/*.yaml (markdown).

  tools/paper003_table.py lab runs/paper003_lab         # Table 1: x / y RMS and max
  tools/paper003_table.py global runs/paper003_global   # Table 2: global localization time
  tools/paper003_table.py matlab runs/paper003_matlab   # the MATLAB-style simulation

Per configuration over its seeds: the x and y errors' RMS and maximum (each run's own, from its
trajectory against the ground truth; mean ± 95 % CI over the runs), the paper's figure beside
them where it has one; for global localization the time to within 0.2 m and 10 deg (held 0.2 s),
median and range, and how many runs got there.
"""
import csv
import math
import statistics
import sys

import locsim_path  # noqa: F401  (this tree's python/locsim first)
import numpy as np

import locsim

# Table 1 of the paper (metres): x RMS, x max, y RMS, y max.
PAPER_TABLE1 = {
    "odometry": (0.178, 0.321, 0.295, 0.476),
    "ultrasonic": (0.092, 0.257, 0.05, 0.435),
    "amcl": (0.035, 0.1, 0.079, 0.25),
    "fusion": (0.017, 0.052, 0.022, 0.091),
}
# Table 2: seconds from 10 random places, (min, mean, max).
PAPER_TABLE2 = {"amcl": (422, 502, 580), "fusion": (1.01, 1.09, 1.19)}


def xy_errors(run_folder, label):
    e = locsim.error_arrays(run_folder, label)
    return np.abs(e["dx_m"]), np.abs(e["dy_m"])


def mean_ci(values):
    mean, ci = locsim.mean_ci(values)
    return f"{mean:.3f} ± {ci:.3f}"


def runs_of(sweep):
    rows = list(csv.DictReader(open(f"{sweep}/results.csv")))
    configs = list(dict.fromkeys(r["config"] for r in rows))
    return rows, configs


def table_errors(sweep, paper):
    rows, configs = runs_of(sweep)
    folders = locsim.load_sweep(sweep)
    print("| filter | x RMS [m] | x max [m] | y RMS [m] | y max [m] | runs ok |")
    print("|---|---|---|---|---|---|")
    for config in configs:
        runs = [r for r in rows if r["config"] == config and r["status"] == "ok"]
        stats = [[], [], [], []]
        for r in runs:
            ex, ey = xy_errors(folders.run_folder(r["id"]), config)
            for k, v in enumerate((math.sqrt(np.mean(ex**2)), ex.max(), math.sqrt(np.mean(ey**2)), ey.max())):
                stats[k].append(v)
        cells = [mean_ci(s) for s in stats]
        if paper and config in PAPER_TABLE1:
            cells = [f"{c} (paper {p})" for c, p in zip(cells, PAPER_TABLE1[config])]
        print(f"| {config} | " + " | ".join(cells) + f" | {len(runs)} of {len([r for r in rows if r['config'] == config])} |")


def table_global(sweep):
    rows, configs = runs_of(sweep)
    print("| filter | localized | time [s], median (min–max) | paper [s], min / mean / max |")
    print("|---|---|---|---|")
    for config in configs:
        runs = [r for r in rows if r["config"] == config]
        times = [float(r["converged_s"]) for r in runs if r["status"] == "ok" and r["converged_s"]]
        span = (f"{statistics.median(times):.2f} ({min(times):.2f}–{max(times):.2f})"
                if times else "never")
        base = config.split("-")[0]
        paper = PAPER_TABLE2.get(base)
        paper_cell = " / ".join(f"{p:g}" for p in paper) if paper else "–"
        print(f"| {config} | {len(times)} of {len(runs)} | {span} | {paper_cell} |")


if __name__ == "__main__":
    kind, sweep = sys.argv[1], sys.argv[2]
    if kind == "lab":
        table_errors(sweep, paper=True)
    elif kind == "matlab":
        table_errors(sweep, paper=False)
    elif kind == "global":
        table_global(sweep)
    else:
        sys.exit(f"unknown table '{kind}' (lab, global, matlab)")
