"""A run folder (of `locsim run` or `locsim replay`) as numpy arrays and pandas DataFrames.

    r = locsim.load_run("runs/demo-kidnap")
    r.labels()                      # the localizers: ['odometry', 'ekf_landmarks', ...]
    r.errors()                      # every localizer's error at every ground-truth time
    r.summary()                     # one row of metrics per localizer
    r.readings("ptz_camera")        # a sensor's readings file

With several robots each method takes `robot=` (a name); without it, the methods that return a
table cover every robot (with a `robot` column) and the others need the run to have one robot.
"""

import math
import os
from collections import namedtuple

import numpy as np

from . import io

Laser = namedtuple("Laser", "t_s ranges_m angles_rad")


class Run:
    """One run folder. `info` is run.json; the rest is read when asked for."""

    def __init__(self, path):
        self.path = os.path.abspath(os.fspath(path))
        info_path = os.path.join(self.path, "run.json")
        if not os.path.isfile(info_path):
            raise FileNotFoundError(f"{self.path} is not a run folder: no run.json")
        self.info = io.read_json(info_path)
        if not isinstance(self.info, dict):
            raise io.FormatError(f"{info_path}: not a JSON object")
        # A run that has not finished (status "running" or "failed") may not list its robots yet.
        robots = self.info.get("robots")
        self._folders = {r["name"]: os.path.join(self.path, r.get("folder", "."))
                         for r in (robots if isinstance(robots, list) else [])}

    def __repr__(self):
        return f"locsim.Run({self.path!r}: {self.status}, seed {self.seed}, robots {self.robots}, localizers {self.labels() if len(self.robots) == 1 else '...'})"

    @property
    def status(self):
        return self.info.get("status")

    @property
    def seed(self):
        return self.info.get("seed")

    @property
    def robots(self):
        """The robots' names, in the world's order."""
        return list(self._folders)

    def _robot(self, robot):
        if robot is None:
            if len(self._folders) != 1:
                raise ValueError(f"{self.path} has robots {self.robots}: name one (robot=...)")
            return self.robots[0]
        if robot not in self._folders:
            raise KeyError(f"{self.path} has no robot {robot!r} (robots: {self.robots})")
        return robot

    def _robots(self, robot):
        return self.robots if robot is None else [self._robot(robot)]

    def folder(self, robot=None):
        """The folder of a robot's files (the run folder itself with one robot)."""
        return self._folders[self._robot(robot)]

    def labels(self, robot=None):
        """The localizers' labels on a robot, as run.json lists them."""
        name = self._robot(robot)
        return [l["label"] for l in self.info.get("localizers", []) if l.get("robot", name) == name]

    def metrics(self, robot=None):
        """metrics.json of a robot, as a dict; {} when the run wrote none (no localizer)."""
        path = os.path.join(self.folder(robot), "metrics.json")
        return io.read_json(path) if os.path.exists(path) else {}

    def localizer_metrics(self, label, robot=None):
        """One localizer's block of metrics.json."""
        for entry in self.metrics(robot).get("localizers", []):
            if entry["label"] == label:
                return entry
        raise KeyError(f"{self.folder(robot)}/metrics.json has no localizer {label!r}")

    def summary(self, robot=None):
        """One row per localizer (and robot): status, the errors' RMS, mean and max, heading RMS,
        convergence, time lost, tracking RMS, NEES and the 95 % ellipse's coverage, and why a
        failed one failed (DataFrame)."""
        import pandas as pd

        rows = []
        for name in self._robots(robot):
            for m in self.metrics(name).get("localizers", []):
                position = m.get("position_error_m") or {}
                heading = m.get("heading_error_deg") or {}
                consistency = m.get("consistency") or {}
                convergence = m.get("convergence") or {}
                failure = m.get("failure") or {}
                tracking = [s["tracking"]["position_rms_m"] for s in m.get("segments", [])
                            if (s.get("tracking") or {}).get("position_rms_m") is not None]
                rows.append({
                    "robot": name, "label": m["label"], "plugin": m.get("plugin"), "status": m.get("status"),
                    "position_rms_m": position.get("rms"), "position_mean_m": position.get("mean"),
                    "position_max_m": position.get("max"), "heading_rms_deg": heading.get("rms"),
                    "converged_s": convergence.get("time_s"), "time_lost_s": m.get("time_lost_s"),
                    "segments": len(m.get("segments", [])),
                    "tracking_position_rms_m": max(tracking) if tracking else None,
                    "nees_mean": consistency.get("nees_mean"), "inside_95_ellipse": consistency.get("inside_95_ellipse"),
                    "failure": f"{failure.get('call')} at {failure.get('t_s')} s: {failure.get('message')}" if failure else None,
                })
        return pd.DataFrame(rows, columns=None if rows else ["robot", "label", "status"]).astype(
            {"position_rms_m": float, "converged_s": float}, errors="ignore")

    def trajectory(self, label, robot=None):
        """A localizer's estimate (LABEL.tum) as an (N, 4) array of t_s, x_m, y_m, theta_rad; empty
        if it wrote none."""
        path = os.path.join(self.folder(robot), label + ".tum")
        return io.read_tum(path) if os.path.exists(path) else np.zeros((0, 4))

    def truth(self, robot=None):
        """The ground truth (groundtruth.tum) as an (N, 4) array of t_s, x_m, y_m, theta_rad (no rows
        while the robot is carried)."""
        return io.read_tum(os.path.join(self.folder(robot), "groundtruth.tum"))

    def groundtruth(self, robot=None):
        """The ground truth as a DataFrame t_s, x_m, y_m, theta_rad."""
        return io.pose_frame(self.truth(robot))

    def estimate(self, label, robot=None):
        """A localizer's estimate as a DataFrame t_s, x_m, y_m, theta_rad."""
        return io.pose_frame(self.trajectory(label, robot))

    def error_arrays(self, label, robot=None):
        """A localizer's error against the ground truth (see `error_arrays`)."""
        return error_arrays(self.folder(robot), label)

    def errors(self, label=None, robot=None):
        """Every localizer's (or `label`'s) error at every ground-truth time it estimated: a DataFrame
        robot, label, t_s, dx_m, dy_m, position_error_m, heading_error_rad. Its RMS per label is
        metrics.json's position_error_m.rms."""
        import pandas as pd

        frames = []
        for name in self._robots(robot):
            for l in ([label] if label is not None else self.labels(name)):
                e = self.error_arrays(l, name)
                frame = pd.DataFrame(e)
                frame.insert(0, "label", l)
                frame.insert(0, "robot", name)
                frames.append(frame)
        if not frames:
            return pd.DataFrame(columns=["robot", "label", "t_s", "dx_m", "dy_m", "position_error_m",
                                         "heading_error_rad"])
        return pd.concat(frames, ignore_index=True)

    def events(self):
        """events.csv as a list of dicts {t_s, kind, robot, details (dict)}."""
        return io.read_events(os.path.join(self.path, "events.csv"))

    def kidnap_times(self, robot=None):
        """The times [s] the robot (or any robot) was picked up."""
        names = set(self._robots(robot))
        return [e["t_s"] for e in self.events() if e["kind"] == "kidnap" and (e["robot"] in names or not e["robot"])]

    def sensors(self, robot=None):
        """readings/sensors.json: each sensor's resolved configuration."""
        return io.read_json(os.path.join(self.folder(robot), "readings", "sensors.json"))

    def readings(self, sensor, robot=None):
        """A sensor's readings file (readings/SENSOR.csv) as a DataFrame, or for `laser` a Laser
        (t_s (N,), ranges_m (N, beams), angles_rad (beams,)). The run must have been made without
        --no-readings."""
        folder = os.path.join(self.folder(robot), "readings")
        path = os.path.join(folder, sensor + ".csv")
        if not os.path.exists(path):
            have = sorted(f[:-4] for f in os.listdir(folder) if f.endswith(".csv")) if os.path.isdir(folder) else []
            raise FileNotFoundError(f"{path} does not exist (readings here: {have or 'none'})")
        if sensor == "laser":
            t, ranges = io.read_laser(path)
            angles = np.asarray(self.sensors(robot)["laser"]["beam_angles_rad"])
            return Laser(t, ranges, angles)
        return io.read_csv(path)

    def landmark_map(self, label, robot=None):
        """A SLAM filter's final map (LABEL_map.csv) as a DataFrame id, x_m, y_m, cov_xx, cov_xy, cov_yy."""
        return io.read_csv(os.path.join(self.folder(robot), label + "_map.csv"))


def error_arrays(folder, label):
    """A localizer's error against the ground truth in a robot's folder, at the times both have,
    as a dict of arrays: t_s, dx_m, dy_m (estimate - truth), position_error_m, heading_error_rad
    (wrapped); empty arrays if either trajectory is missing (a merged sweep keeps no runs)."""
    truth_path, estimate_path = os.path.join(folder, "groundtruth.tum"), os.path.join(folder, label + ".tum")
    if not (os.path.exists(truth_path) and os.path.exists(estimate_path)):
        truth = estimate = np.zeros((0, 4))
    else:
        truth, estimate = io.read_tum(truth_path), io.read_tum(estimate_path)
    i, j = io.join_on_time(truth, estimate)
    dx, dy = estimate[j, 1] - truth[i, 1], estimate[j, 2] - truth[i, 2]
    return {"t_s": truth[i, 0], "dx_m": dx, "dy_m": dy, "position_error_m": np.hypot(dx, dy),
            "heading_error_rad": io.wrap_angle(estimate[j, 3] - truth[i, 3])}


def load_run(path):
    """The run folder at `path` (one holding run.json)."""
    return Run(path)


def rms(values):
    """Root mean square of `values` (nan for none)."""
    v = np.asarray(values, dtype=float)
    return math.sqrt(float(np.mean(v * v))) if v.size else math.nan
