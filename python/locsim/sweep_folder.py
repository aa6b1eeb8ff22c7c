"""A sweep folder (of `locsim sweep`, or `locsim merge`) as pandas DataFrames and Runs.

    s = locsim.load_sweep("runs/suite")
    s.results                       # results.csv: one row per run (config, seed, world, metrics)
    s.summary                       # summary.csv: one row per configuration, with 95 % CIs
    s.segments()                    # segments.csv: one row per run and segment between kidnaps
    s.errors("amcl")                # every amcl run's error series, with config, seed and world
    for row, run in s.runs(): ...   # each run's row of results.csv and its Run folder

docs/experiments.md describes the folder: results.jsonl is the record of each run (the newest
line of a run wins, as a resumed sweep appends), results.csv and summary.csv its tables.
"""

import os

from . import io
from .run_folder import Run


class Sweep:
    """One sweep folder. `info` is sweep.json; tables are read when first asked for."""

    def __init__(self, path):
        self.path = os.path.abspath(os.fspath(path))
        info_path = os.path.join(self.path, "sweep.json")
        if not os.path.isfile(info_path):
            raise FileNotFoundError(f"{self.path} is not a sweep folder: no sweep.json")
        self.info = io.read_json(info_path)
        self._results = self._summary = self._records = None

    def __repr__(self):
        return f"locsim.Sweep({self.path!r}: {len(self.results)} runs of {self.configs})"

    @property
    def results(self):
        """results.csv: one row per run (DataFrame); empty numbers are NaN."""
        if self._results is None:
            self._results = io.read_csv(os.path.join(self.path, "results.csv"))
        return self._results

    @property
    def summary(self):
        """summary.csv: one row per configuration with means, 95 % CIs and medians (DataFrame)."""
        if self._summary is None:
            self._summary = io.read_csv(os.path.join(self.path, "summary.csv"))
        return self._summary

    def segments(self, config=None):
        """segments.csv: one row per run and segment between kidnaps (DataFrame, tidy): segment 0
        runs from the start to the first kidnap, segment k from the k-th kidnap on, with its
        position and heading RMS, recovery, tracking RMS and consistency (NEES, the 95 % ellipse's
        share), and whether the scorer judged the kidnap recoverable. Those of `config` (all if
        None). A sweep written before segments.csv existed has its rows rebuilt from results.jsonl."""
        path = os.path.join(self.path, "segments.csv")
        if os.path.exists(path):
            frame = io.read_csv(path)
        else:
            frame = self._segments_from_records()
        if config is not None:
            frame = frame[frame["config"] == config].reset_index(drop=True)
        return frame

    def _segments_from_records(self):
        import pandas as pd

        rows = []
        for record in sorted(self.records().values(), key=lambda r: r.get("index", 0)):
            metrics = record.get("metrics") or {}
            for k, s in enumerate(metrics.get("segments", [])):
                consistency = s.get("consistency") or {}
                rows.append({"index": record.get("index"), "id": record.get("id"), "config": record.get("config"),
                             "seed": record.get("seed"), "world": record.get("world"), "segment": k,
                             "from_s": s.get("from_s"), "to_s": s.get("to_s"), "samples": s.get("samples"),
                             "carried_m": s.get("carried_m"), "turned_deg": s.get("turned_deg"),
                             "recoverable": s.get("recoverable"), "recovery_s": s.get("recovery_s"),
                             "recovery_steps": s.get("recovery_steps"),
                             "position_rms_m": (s.get("position_error_m") or {}).get("rms"),
                             "heading_rms_deg": (s.get("heading_error_deg") or {}).get("rms"),
                             "tracking_position_rms_m": (s.get("tracking") or {}).get("position_rms_m"),
                             "nees_mean": consistency.get("nees_mean"), "nees_median": consistency.get("nees_median"),
                             "inside_95_ellipse": consistency.get("inside_95_ellipse"),
                             "tracking_inside_95_ellipse": (s.get("tracking") or {}).get("inside_95_ellipse"),
                             "jumps": (s.get("jumps") or {}).get("count")})
        columns = ["index", "id", "config", "seed", "world", "segment", "from_s", "to_s", "samples", "carried_m",
                   "turned_deg", "recoverable", "recovery_s", "recovery_steps", "position_rms_m", "heading_rms_deg",
                   "tracking_position_rms_m", "nees_mean", "nees_median", "inside_95_ellipse",
                   "tracking_inside_95_ellipse", "jumps"]
        return pd.DataFrame(rows, columns=columns)

    def summary_by_family(self):
        """summary_by_family.csv of a suite of worlds (DataFrame)."""
        return io.read_csv(os.path.join(self.path, "summary_by_family.csv"))

    def summary_by_part(self):
        """summary_by_part.csv of a suite with held-back worlds (DataFrame): per configuration, the
        part the defaults were chosen on and the held-back part."""
        return io.read_csv(os.path.join(self.path, "summary_by_part.csv"))

    @property
    def configs(self):
        """The configurations, in the experiment's order."""
        return list(dict.fromkeys(self.results["config"]))

    def records(self):
        """results.jsonl as a dict {run id: record} (the newest line of each run), each record with
        its params, status and whole metrics block."""
        if self._records is None:
            self._records = {}
            path = os.path.join(self.path, "results.jsonl")
            if os.path.exists(path):
                for record in io.read_jsonl(path):
                    if "id" in record:
                        self._records[record["id"]] = record
        return self._records

    def run_folder(self, run_id):
        """The folder of the run `run_id` (results.csv's `id`, e.g. 'amcl/seed-3')."""
        record = self.records().get(run_id)
        if record and record.get("log"):
            return os.path.join(self.path, os.path.dirname(record["log"]))
        return os.path.join(self.path, "runs", run_id)

    def run(self, config, seed, world=None):
        """The Run of `config` at `seed` (and `world`, a world's file stem or family member, in a
        suite of several worlds)."""
        rows = self.results[(self.results["config"] == config) & (self.results["seed"] == int(seed))]
        if world is not None:
            rows = rows[rows["world"] == world]
        if len(rows) != 1:
            raise KeyError(f"{self.path}: {len(rows)} runs of config {config!r}, seed {seed}"
                           + (f", world {world!r}" if world is not None else "")
                           + ("" if rows.empty else f" (worlds {sorted(set(rows['world']))}: name one)"))
        return Run(self.run_folder(rows.iloc[0]["id"]))

    def runs(self, config=None, status="ok"):
        """Each run's (row of results.csv as a dict, Run), in results.csv's order: those of `config`
        (all configurations if None) whose status is `status` (all if None) and whose folder has
        run.json."""
        for row in self.results.to_dict("records"):
            if config is not None and row["config"] != config:
                continue
            if status is not None and row["status"] != status:
                continue
            folder = self.run_folder(row["id"])
            if os.path.isfile(os.path.join(folder, "run.json")):
                yield row, Run(folder)

    def errors(self, config=None, status="ok"):
        """The error series of every run (see Run.errors) with the run's config, seed and world
        (DataFrame); a run's localizer is labelled with its config."""
        import pandas as pd

        frames = []
        for row, run in self.runs(config, status):
            label = row["config"] if row["config"] in run.labels() else None
            frame = run.errors(label)
            frame.insert(0, "world", row.get("world"))
            frame.insert(0, "seed", row["seed"])
            frame.insert(0, "config", row["config"])
            frames.append(frame)
        if not frames:
            return pd.DataFrame(columns=["config", "seed", "world", "robot", "label", "t_s", "dx_m", "dy_m",
                                         "position_error_m", "heading_error_rad"])
        return pd.concat(frames, ignore_index=True)


def load_sweep(path):
    """The sweep folder at `path` (one holding sweep.json)."""
    return Sweep(path)
