#!/usr/bin/python3
"""Measures a robot's odometry error per perception step, to set a particle filter's motion noise.

    tools/odometry_error.py RUN_DIR [RUN_DIR ...] [--step-s 0.2]

Compares, over every interval of --step-s seconds, the motion the wheel odometry reports
(readings/encoders.csv) with the true motion (groundtruth.tum), both in the robot's frame at the
interval's start. Prints the mean motion per step and the error's spread along, across and in
heading, straight and turning; the α of the odometry motion model should cover these.
"""
import argparse
import csv
import math
import os
import statistics

import locsim_path  # noqa: F401  (this tree's python/locsim first)
import locsim


def wrap(a):
    return math.remainder(a, 2 * math.pi)


def between(p, q):
    c, s = math.cos(p[2]), math.sin(p[2])
    dx, dy = q[0] - p[0], q[1] - p[1]
    return c * dx + s * dy, -s * dx + c * dy, wrap(q[2] - p[2])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+")
    parser.add_argument("--step-s", type=float, default=0.2, help="perception step [s]")
    args = parser.parse_args()
    rows = []
    for run in args.runs:
        truth, odom = {}, {}
        for t, x, y, theta in locsim.read_tum(os.path.join(run, "groundtruth.tum")).tolist():
            truth[round(t / args.step_s)] = (x, y, theta)
        with open(os.path.join(run, "readings", "encoders.csv"), newline="") as f:
            for r in csv.DictReader(f):
                t = float(r["t_s"])
                k = round(t / args.step_s)
                if abs(k * args.step_s - t) < 1e-6:
                    odom[k] = (float(r["odom_x_m"]), float(r["odom_y_m"]), float(r["odom_theta_rad"]))
        keys = sorted(k for k in truth if k in odom and k + 1 in truth and k + 1 in odom)
        for k in keys:
            o, g = between(odom[k], odom[k + 1]), between(truth[k], truth[k + 1])
            rows.append((math.hypot(o[0], o[1]), abs(o[2]), o[0] - g[0], o[1] - g[1], wrap(o[2] - g[2])))
    if len(rows) < 2:
        raise SystemExit("too few steps: are groundtruth.tum and encoders.csv sampled at the step?")
    for name, sel in (("all", rows), ("straight", [r for r in rows if r[1] <= 0.05]),
                      ("turning", [r for r in rows if r[1] > 0.05])):
        if len(sel) < 2:
            continue
        print(f"{name:9s} {len(sel):5d} steps: travel {statistics.fmean(r[0] for r in sel):.4f} m, "
              f"turn {statistics.fmean(r[1] for r in sel):.4f} rad | error sd: along "
              f"{statistics.stdev(r[2] for r in sel):.5f} m, across {statistics.stdev(r[3] for r in sel):.5f} m, "
              f"heading {statistics.stdev(r[4] for r in sel):.5f} rad (mean {statistics.fmean(r[4] for r in sel):+.5f})")


if __name__ == "__main__":
    main()
