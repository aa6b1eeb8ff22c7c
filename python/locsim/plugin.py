"""Localizers written in Python: the base class, parameter declarations and what a filter is
told at creation. The host (plugins/python, `--localizer python:my_filter.py`) imports the file,
makes its one `Localizer` subclass with an `Init`, and calls its handlers with each reading:

    import numpy as np
    import locsim

    class DeadReckoning(locsim.Localizer):
        \"\"\"Follows the wheel odometry from the initial guess.\"\"\"      # the description
        params = [locsim.param("noise", float, 0.01, 0.0, 1.0, "growth of the variance [m^2/m]")]

        def on_odometry(self, t_s, odometry): ...                       # odometry.pose, ...
        def estimate(self):
            return pose, covariance                                     # (3,), (3, 3)

Handlers (define those the filter uses; the others' readings are not delivered), each called with
the reading's time [s] and the reading:
    on_odometry(t_s, o)   o.pose (x, y, theta in the odom frame), o.left_ticks, o.right_ticks,
                          o.meters_per_tick, o.v_mps, o.omega_radps, o.fields (LOCSIM_ODOMETRY_*)
    on_imu(t_s, m)        m.yaw_rate_radps, m.accel_x_mps2, m.accel_y_mps2, m.mount_theta
    on_landmarks(t_s, c)  c.camera (PTZ, OMNI, RANGE_BEARING), c.pan_rad, c.detections: a
                          structured array with fields id, range_m, bearing_rad, target; c.colors
    on_beacon_ranges(t_s, r)  a structured array: receiver, beacon_id, range_m (NaN: no echo),
                          receiver_x, receiver_y, receiver_height_m
    on_laser(t_s, s)      s.ranges (float32), s.angles (float32), s.mount (x, y, theta),
                          s.range_min, s.range_max
Required: estimate() -> (pose (3,), covariance (3, 3)). Optional: particles() -> poses (N, 3) or
(poses, weights (N,)); diagnostics() -> {name: number}; landmark_map() -> (ids (N,), xy (N, 2),
covariances (N, 2, 2)).

Arrays handed to a handler are read-only views of the host's memory, valid during the call only:
copy what you keep (np.array(x)). docs/python.md has the whole interface.

The host reads `name`, the docstring's first line, `params` and which handlers are defined from
the file's text, without running it: they must be literals in the class body.
"""

from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

# locsim_camera_kind, locsim_target and locsim_odometry_field of the C ABI (localizer.h).
PTZ, OMNI, RANGE_BEARING = 0, 1, 2
LANDMARK, ROBOT = 0, 1
ODOMETRY_TICKS, ODOMETRY_POSE, ODOMETRY_VELOCITY = 1, 2, 4


class Param(NamedTuple):
    name: str
    type: type
    default: Any
    min: Any = None
    max: Any = None
    doc: str = ""


def param(name, type, default, min=None, max=None, doc=""):  # noqa: A002  (the C++ SDK's names)
    """A parameter the filter declares: its name ([a-z0-9_]+), type (int, float, bool or str),
    default, inclusive range (numbers) and a one-line doc with the unit. Users set it as any
    plugin's: `--localizer python:f.py:name=value`, an experiment's `params:`, a params file."""
    return Param(name, type, default, min, max, doc)


@dataclass
class Init:
    """What a filter is told at creation (locsim_init of the C ABI); never the truth."""

    params: dict                    # every declared parameter, validated, defaults filled in
    seed: int                       # the run's seed for this localizer ("localizer/ROBOT/LABEL")
    rng: np.random.Generator        # numpy's generator seeded with it: use it for determinism
    initial_pose_known: bool        # False: localize globally
    initial_pose: np.ndarray        # (3,) x, y, theta: the guess, drawn around the truth
    initial_covariance: np.ndarray  # (3, 3) of the guess
    landmarks: np.ndarray           # (N, 2) x, y [m]; empty for SLAM (landmarks unknown)
    landmark_ids: np.ndarray        # (N,) int
    landmark_colors: list           # N names or "#rrggbb"
    landmark_radii: np.ndarray      # (N,) [m]
    beacons: np.ndarray             # (M, 3) x, y, height [m]
    beacon_ids: np.ndarray          # (M,) int
    grid: np.ndarray                # (rows, cols) uint8, 0 free, 100 occupied; row 0 the bottom
    grid_origin: tuple              # (x, y) of cell (0, 0)'s corner [m]
    grid_resolution_m: float        # cell size [m]
    wheel_base_m: float
    wheel_radius_m: float
    footprint_radius_m: float
    extra: dict = field(default_factory=dict)


class Localizer:
    """Base of a localizer written in Python. Subclass it once per file; see the module's doc."""

    name = None   # [a-z0-9_]+; default: the file's name
    params = ()   # [locsim.param(...), ...]

    def __init__(self, init):
        self.init = init

    def estimate(self):
        raise NotImplementedError(f"{type(self).__name__} defines no estimate()")
