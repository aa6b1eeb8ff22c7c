"""Readers of the files locsim writes, one per format (README "A run folder holds", docs/sensors.md
"Readings files", docs/experiments.md "A sweep folder").

Poses come back as numpy arrays of rows (t_s, x_m, y_m, theta_rad); tables as pandas DataFrames
with the files' own column names. Timestamps are written with 4 decimals, so `time_key` (t in
units of 0.1 ms, an integer) joins a trajectory to the ground truth exactly.
"""

import csv
import io as _io
import json
import math
import os
import warnings

import numpy as np

POSE_COLUMNS = ("t_s", "x_m", "y_m", "theta_rad")


def wrap_angle(a):
    """Angles (scalar or array) wrapped into (-pi, pi], the interval of the C++ SDK's wrap: pi
    stays pi and -pi becomes pi, so that a Python filter and a C++ one agree at the seam."""
    w = np.remainder(np.asarray(a, dtype=float) + math.pi, 2 * math.pi) - math.pi  # [-pi, pi)
    return np.where(w <= -math.pi, w + 2 * math.pi, w)[()]


def read_tum(path):
    """A TUM trajectory (`t x y z qx qy qz qw` per line, '#' comments) as an (N, 4) float array of
    t_s, x_m, y_m, theta_rad (the yaw of the planar quaternion, 2 atan2(qz, qw), in [-pi, pi])."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "input contained no data": an empty trajectory
        try:
            raw = np.loadtxt(path, comments="#", ndmin=2)
        except ValueError as error:
            raise ValueError(f"{path}: not a TUM trajectory ({error})") from None
    if raw.size == 0:
        return np.zeros((0, 4))
    if raw.shape[1] != 8:
        raise ValueError(f"{path}: a TUM line has 8 numbers (t x y z qx qy qz qw), not {raw.shape[1]}")
    theta = wrap_angle(2.0 * np.arctan2(raw[:, 6], raw[:, 7]))
    return np.column_stack((raw[:, 0], raw[:, 1], raw[:, 2], theta))


def time_key(t_s):
    """Times as integers in 0.1 ms, the precision every locsim file writes them with: equal keys
    are the same instant, whatever the float rounding."""
    return np.rint(np.asarray(t_s, dtype=float) * 1e4).astype(np.int64)


def join_on_time(truth, estimate):
    """Indices (i, j) such that truth[i] and estimate[j] (arrays with the time in column 0) are at
    the same instant; estimates are written at the ground truth's times, so rows pair exactly."""
    _, i, j = np.intersect1d(time_key(truth[:, 0]), time_key(estimate[:, 0]), assume_unique=False,
                             return_indices=True)
    return i, j


def pose_frame(poses):
    """An (N, 4) pose array as a DataFrame with POSE_COLUMNS."""
    import pandas as pd

    return pd.DataFrame(np.asarray(poses).reshape(-1, 4), columns=list(POSE_COLUMNS))


def read_csv(path):
    """A CSV file with a header as a DataFrame (pandas)."""
    import pandas as pd

    return pd.read_csv(path)


def read_json(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def read_jsonl(path):
    """The objects of a JSON-lines file (a sweep's results.jsonl). A sweep writes each line whole
    in one write, so one killed while writing leaves at most its last line cut short, without its
    line break: that line is skipped. Any other line that is not a JSON object is corruption:
    ValueError naming the file and line (skipping it would lose it silently)."""
    with open(path, encoding="utf-8", errors="replace") as f:
        text = f.read()
    lines = text.split("\n")
    out = []
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except ValueError:
            record = None
        if isinstance(record, dict):
            out.append(record)
            continue
        if number == len(lines) and record is None:  # the last line, cut short
            break
        excerpt = line if len(line) <= 60 else f"{line[:60]}... ({len(line)} characters)"
        raise ValueError(f"{path}:{number}: not a JSON object (a line cut short or edited; only the "
                         f"last line may be, by a sweep killed while writing it): {excerpt!r}")
    return out


def parse_details(text):
    """events.csv's `details` ("from=(1,2,3) carry_s=2.000 to=(...)") as a dict of strings; a
    value like "(x,y,theta)" becomes a tuple of floats."""
    out = {}
    for item in str(text).split():
        key, _, value = item.partition("=")
        if value.startswith("(") and value.endswith(")"):
            try:
                out[key] = tuple(float(v) for v in value[1:-1].split(","))
                continue
            except ValueError:
                pass
        out[key] = value
    return out


def read_events(path):
    """events.csv as a list of dicts {t_s (float), kind, robot, details (dict)}; [] when the
    file does not exist (a folder written before events were logged)."""
    if not os.path.exists(path):
        return []
    with open(path, newline="", encoding="utf-8") as f:
        return [{"t_s": float(r["t_s"]), "kind": r["kind"], "robot": r["robot"],
                 "details": parse_details(r["details"])} for r in csv.DictReader(f)]


def read_laser(path):
    """readings/laser.csv (`t_s,ranges_m` with the ranges space-separated) as (t_s (N,), ranges_m
    (N, beams) float32); a missing return is written as it was measured (max range or inf)."""
    times, ranges = [], []
    with open(path, encoding="utf-8") as f:
        header = f.readline()
        if not header.startswith("t_s"):
            raise ValueError(f"{path}: not a laser readings file (header {header.strip()!r})")
        for line in f:
            t, _, values = line.rstrip("\n").partition(",")
            times.append(float(t))
            ranges.append(values)
    if not times:
        return np.zeros(0), np.zeros((0, 0), dtype=np.float32)
    beams = np.loadtxt(_io.StringIO("\n".join(ranges)), dtype=np.float32, ndmin=2)
    return np.array(times), beams
