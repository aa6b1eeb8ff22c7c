#!/usr/bin/python3
"""Paper 002's comparison table from a sweep of worlds/omni/experiments/fusion.yaml (markdown).

  tools/paper002_table.py runs/omni_fusion > table.md

Per configuration over its seeds: position RMS (mean, 95 % CI), the largest error after the
first 3 s (the multi-frame window filling; median and IQR), the share of time above 200 mm and
the first time above 500 mm (medians), from each run's trajectory against the ground truth.
"""
import csv
import glob
import math
import statistics
import sys

import numpy as np

SETTLE_S = 3.0


def error_series(run_dir):
    truth = np.loadtxt(f"{run_dir}/groundtruth.tum")
    estimate_file = [f for f in glob.glob(f"{run_dir}/*.tum") if not f.endswith("groundtruth.tum")]
    estimate = np.loadtxt(estimate_file[0])
    j = np.searchsorted(truth[:, 0], estimate[:, 0]).clip(0, len(truth) - 1)
    return estimate[:, 0], np.hypot(estimate[:, 1] - truth[j, 1], estimate[:, 2] - truth[j, 2])


def main(sweep):
    rows = list(csv.DictReader(open(f"{sweep}/results.csv")))
    configs = list(dict.fromkeys(r["config"] for r in rows))
    print("| filter | position RMS [mm], mean ± 95 % CI | max error after 3 s [mm], median (IQR) "
          "| time above 200 mm [%], median | first time above 500 mm [s], median |")
    print("|---|---|---|---|---|")
    for config in configs:
        runs = [r for r in rows if r["config"] == config and r["status"] == "ok"]
        rms = [1000 * float(r["position_rms_m"]) for r in runs]
        peaks, above, first = [], [], []
        for r in runs:
            t, e = error_series(f"{sweep}/runs/{config}/seed-{r['seed']}")
            keep = t >= SETTLE_S
            t, e = t[keep], e[keep]
            peaks.append(1000 * e.max())
            above.append(100 * np.mean(e > 0.2))
            if np.any(e > 0.5):
                first.append(t[np.argmax(e > 0.5)])
        ci = 1.96 * statistics.stdev(rms) / math.sqrt(len(rms)) if len(rms) > 1 else float("nan")
        q = np.percentile(peaks, [25, 50, 75])
        crossed = (f"{statistics.median(first):.0f} ({len(first)} of {len(runs)} runs)"
                   if first else "never")
        name = config.replace("multi_frame-frames=", "multi-frame, frames=")
        print(f"| {name} | {statistics.mean(rms):.0f} ± {ci:.0f} | {q[1]:.0f} ({q[0]:.0f}–{q[2]:.0f}) "
              f"| {statistics.median(above):.0f} | {crossed} |")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "runs/omni_fusion")
