#!/usr/bin/python3
"""Paper 002's comparison table from a sweep of worlds/omni/experiments/fusion.yaml (markdown).

  tools/paper002_table.py runs/omni_fusion > table.md

Per configuration over its seeds: position RMS (mean, 95 % CI), the largest error after the
first 3 s (the multi-frame window filling; median and IQR), the share of time above 200 mm and
the first time above 500 mm (medians), from each run's trajectory against the ground truth.
"""
import csv
import statistics
import sys

import locsim_path  # noqa: F401  (this tree's python/locsim first)
import numpy as np

import locsim

SETTLE_S = 3.0


def main(sweep):
    folders = locsim.load_sweep(sweep)
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
            e = locsim.error_arrays(folders.run_folder(r["id"]), config)
            t, e = e["t_s"], e["position_error_m"]
            keep = t >= SETTLE_S
            t, e = t[keep], e[keep]
            peaks.append(1000 * e.max())
            above.append(100 * np.mean(e > 0.2))
            if np.any(e > 0.5):
                first.append(t[np.argmax(e > 0.5)])
        mean, ci = locsim.mean_ci(rms)
        q = np.percentile(peaks, [25, 50, 75])
        crossed = (f"{statistics.median(first):.0f} ({len(first)} of {len(runs)} runs)"
                   if first else "never")
        name = config.replace("multi_frame-frames=", "multi-frame, frames=")
        print(f"| {name} | {mean:.0f} ± {ci:.0f} | {q[1]:.0f} ({q[0]:.0f}–{q[2]:.0f}) "
              f"| {statistics.median(above):.0f} | {crossed} |")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "runs/omni_fusion")
