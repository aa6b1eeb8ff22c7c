"""locsim from Python: load run and sweep folders as numpy arrays and pandas DataFrames, compute
the project's statistics, drive the `locsim` binary (run, replay, sweep, report), step a world
(World), and write localizers (Localizer, with the filter maths of models and particles).

    >>> import locsim
    >>> r = locsim.load_run("runs/demo-kidnap")
    >>> r.errors().groupby("label").position_error_m.describe()
    >>> s = locsim.load_sweep("runs/suite")
    >>> s.results.groupby("config").position_rms_m.apply(locsim.mean_ci)

Everything here reads the folders' documented formats (docs/run_folder.md, docs/experiments.md);
nothing needs the C++ build except `locsim.run`, `replay`, `sweep` and `report`, which call the
binary.
numpy is needed throughout, pandas only by the functions that return DataFrames. docs/python.md
has the whole interface.
"""

import os as _os
import sys as _sys


def _find_debian_numpy():
    # A Python other than Debian's own (pyenv, a venv) of the same minor version can use the
    # numpy and pandas Debian installs (python3-numpy, python3-pandas, from tools/setup): append
    # Debian's folder only when numpy is missing, so an environment's own numpy always wins.
    try:
        import numpy  # noqa: F401  (only whether it imports)
    except ImportError:
        debian = "/usr/lib/python3/dist-packages"
        abi = f"cpython-{_sys.version_info.major}{_sys.version_info.minor}"
        core = _os.path.join(debian, "numpy", "core")
        if _os.path.isdir(core) and any(abi in name for name in _os.listdir(core)):
            _sys.path.append(debian)


_find_debian_numpy()

from .cli import LocsimError, binary, replay, report, run, sweep  # noqa: E402
from .io import read_events, read_tum, wrap_angle  # noqa: E402
from .models import (K_LEFT, K_RIGHT, DetectionNoise, LostWatch, OdometryNoise, add_motion_floor,  # noqa: E402
                     advance_by_velocity, between, compose, decompose, detection_noise_params, diff_drive_motion,
                     landmark_log_likelihood, landmark_log_match, lost_params, motion_noise_params, motion_spread,
                     numeric_jacobian, predict_by_wheels, range_bearing, sample_motion,
                     sample_wheel_motion, sinc, wheel_travel_from_increment)
from .particles import (circular_mean, effective_sample_size, free_space_poses,  # noqa: E402
                        low_variance_resample, mean_and_covariance, normalize, roulette_resample,
                        weights_from_log)
from .plugin import Init, Localizer, Param, param  # noqa: E402
from .run_folder import Run, error_arrays, load_run  # noqa: E402
from .stats import Aggregate, aggregate, mean_ci, t975  # noqa: E402
from .sweep_folder import Sweep, load_sweep  # noqa: E402
from .world import World  # noqa: E402

__all__ = ["Aggregate", "DetectionNoise", "Init", "K_LEFT", "K_RIGHT", "Localizer", "LocsimError", "LostWatch",
           "OdometryNoise",
           "Param", "Run", "Sweep", "World", "add_motion_floor", "advance_by_velocity", "aggregate", "between",
           "binary", "circular_mean", "compose", "decompose", "detection_noise_params", "diff_drive_motion",
           "effective_sample_size", "error_arrays", "free_space_poses",
           "landmark_log_likelihood", "landmark_log_match", "load_run", "load_sweep", "lost_params",
           "low_variance_resample", "mean_and_covariance", "mean_ci", "motion_noise_params", "motion_spread",
           "normalize", "numeric_jacobian", "param", "predict_by_wheels", "range_bearing",
           "read_events", "read_tum", "replay", "report", "roulette_resample", "run",
           "sample_motion", "sample_wheel_motion", "sinc", "sweep", "t975", "weights_from_log",
           "wheel_travel_from_increment", "wrap_angle"]
