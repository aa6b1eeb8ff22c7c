"""Readers of the files locsim writes, one per format (docs/run_folder.md "What a run folder
holds", docs/sensors.md "Readings files", docs/experiments.md "A sweep folder").

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


class FormatError(ValueError):
    """A file is not as locsim writes it (not UTF-8, not valid JSON, a row that is not numbers):
    the message names the file, and the line (and column) where there is one."""


def _excerpt(text, limit=60):
    """`text` fit to quote in a message: repr() escapes control characters, cut after `limit`."""
    text = str(text)
    return repr(text) if len(text) <= limit else f"{text[:limit]!r}... ({len(text)} characters)"


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
            raw = np.loadtxt(path, comments="#", ndmin=2, encoding="utf-8")
        except ValueError:  # UnicodeDecodeError too
            raise FormatError(_bad_tum_line(path) or f"{path}: not a TUM trajectory") from None
    if raw.size == 0:
        return np.zeros((0, 4))
    if raw.shape[1] != 8:
        raise FormatError(f"{path}: a TUM line has 8 numbers (t x y z qx qy qz qw), not {raw.shape[1]}")
    theta = wrap_angle(2.0 * np.arctan2(raw[:, 6], raw[:, 7]))
    return np.column_stack((raw[:, 0], raw[:, 1], raw[:, 2], theta))


def _bad_tum_line(path):
    """The message for the first line of `path` that is not a TUM line ('PATH:LINE: ...'), or None
    if none is found. numpy's own message counts rows, not lines, and suggests `usecols`."""
    with open(path, "rb") as f:
        for number, raw in enumerate(f, start=1):
            try:
                line = raw.decode("utf-8")
            except UnicodeDecodeError as error:
                return f"{path}:{number}: not UTF-8 (byte 0x{raw[error.start]:02x})"
            fields = line.split("#", 1)[0].split()
            if not fields:
                continue
            if len(fields) != 8:
                return (f"{path}:{number}: a TUM line has 8 numbers (t x y z qx qy qz qw), not "
                        f"{len(fields)}: {_excerpt(line.rstrip())}")
            for field in fields:
                try:
                    float(field)
                except ValueError:
                    return f"{path}:{number}: {_excerpt(field)} is not a number"
    return None


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
    """A JSON file's value. FormatError names the file, and the line and column, when it is not
    UTF-8 or not valid JSON (a file cut short, say); OSError when it cannot be read."""
    with open(path, "rb") as f:
        data = f.read()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as error:
        line = data.count(b"\n", 0, error.start) + 1
        column = error.start - (data.rfind(b"\n", 0, error.start) + 1) + 1
        raise FormatError(f"{path}:{line}:{column}: not UTF-8 (byte 0x{data[error.start]:02x})") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as error:
        raise FormatError(f"{path}:{error.lineno}:{error.colno}: not valid JSON ({error.msg})") from None
    except RecursionError:
        raise FormatError(f"{path}: not valid JSON (nested too deeply)") from None


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
        raise FormatError(f"{path}:{number}: not a JSON object (a line cut short or edited; only "
                          f"the last line may be, by a sweep killed while writing it): "
                          f"{_excerpt(line)}")
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
    events = []
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        try:
            missing = [c for c in ("t_s", "kind") if c not in (reader.fieldnames or [])]
            if missing:
                raise FormatError(f"{path}:1: no column {', '.join(missing)} (not an events file)")
            for r in reader:
                try:
                    t = float(r["t_s"])
                except (TypeError, ValueError):
                    raise FormatError(f"{path}:{reader.line_num}: t_s {_excerpt(r['t_s'])} is not a "
                                      "number") from None
                events.append({"t_s": t, "kind": r["kind"] or "", "robot": r.get("robot") or "",
                               "details": parse_details(r.get("details") or "")})
        except UnicodeDecodeError as error:
            raise FormatError(f"{path}: not UTF-8 (byte 0x{error.object[error.start]:02x})") from None
        except csv.Error as error:
            raise FormatError(f"{path}:{reader.line_num}: not a CSV file ({error})") from None
    return events


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
