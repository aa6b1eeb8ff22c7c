"""The noise parameters the built-in C++ filters declare (and the LostWatch's), as plain data (names, types, defaults,
ranges and docs as plugins/particle_filters/landmark_pf.hpp and the SDK's models.hpp declare them),
so that a Python filter declares them alike and one parameter file (the one `locsim calibrate`
writes) sets it as it sets the built-in ones. Standard library only: _describe.py, which reads a
filter's declarations without running it (no numpy), expands `locsim.detection_noise_params()`
and `locsim.motion_noise_params()` from here; models.py makes them locsim.param's."""

# Paper 002's wheel noise, the C++ SDK's defaults (LOCSIM_WHEEL_NOISE_PARAMS) [m^1/2].
K_LEFT, K_RIGHT = 0.0013, 0.0012

# (name, type, default, min, max, doc), as locsim.param takes them.
DETECTION_NOISE = [
    ("sigma_range_m", float, 0.02, 1e-6, 100.0, "range noise of a detection at zero range [m]"),
    ("sigma_range_per_m", float, 0.0, 0.0, 10.0, "growth of the range noise with the measured range [m/m]"),
    ("sigma_range_per_m2", float, 0.015, 0.0, 10.0,
     "growth with the square of the range (a row of a pinhole image) [1/m]"),
    ("sigma_bearing_deg", float, 2.0, 1e-6, 180.0, "bearing noise of a detection [deg]"),
]

MOTION_NOISE = [
    ("alpha1", float, 0.0014, 0.0, 10.0, "rotation noise from rotation (paper 004) [-]"),
    ("alpha2", float, 0.000125, 0.0, 10.0, "rotation noise from translation [rad/m]"),
    ("alpha3", float, 0.01, 0.0, 10.0, "translation noise from translation [-]"),
    ("alpha4", float, 0.26, 0.0, 10.0, "translation noise from rotation [m/rad]"),
    ("variance_form", bool, False, None, None, "Thrun's variance form of the motion noise"),
    ("motion_model", str, "odometry", None, None,
     "odometry: alpha1..alpha4 on the motion since the last step; wheels: each odometry reading's "
     "wheel travel with variance k^2 |d| per wheel (k_left, k_right)"),
    ("k_left", float, K_LEFT, 0.0, 1.0, "motion_model wheels: left wheel random error [m^1/2]"),
    ("k_right", float, K_RIGHT, 0.0, 1.0, "motion_model wheels: right wheel random error [m^1/2]"),
    ("motion_floor_m", float, 0.0, 0.0, 10.0,
     "position noise of every step whatever its motion, per axis: the robot's (locsim calibrate) [m]"),
    ("motion_floor_deg", float, 0.0, 0.0, 180.0,
     "heading noise of every step whatever its motion: the robot's (locsim calibrate) [deg]"),
    ("roughening_m", float, 0.005, 0.0, 10.0,
     "position noise added to every particle at every step beside the motion floor (in quadrature), "
     "so that a finite set of particles does not collapse [m]"),
    ("roughening_deg", float, 0.5, 0.0, 180.0, "heading noise added likewise [deg]"),
]

# When a filter with a gate is lost, and how its covariance widens then (LOCSIM_LOST_PARAMS, the
# SDK's LostWatch, as ekf_landmarks declares them).
LOST = [
    ("lost_after_rejections", int, 12, 0, 1000000,
     "detections rejected in excess of those accepted (a running count, +1 a rejection, -1 an acceptance, "
     "never below 0) that say the pose is lost (a push the wheels did not feel, a kidnap): from then on each "
     "rejection widens its covariance (0: never) [-]"),
    ("lost_growth_m", float, 0.5, 0.0, 100.0, "... its position spread grows by this per root second while lost [m/sqrt(s)]"),
    ("lost_growth_deg", float, 20.0, 0.0, 180.0, "... its heading spread by this [deg/sqrt(s)]"),
    ("lost_max_m", float, 3.0, 0.0, 1000.0, "... up to this position spread [m]"),
    ("lost_max_deg", float, 60.0, 0.0, 180.0, "... and this heading spread [deg]"),
]

# The calls a filter's `params` may add, by name.
LISTS = {"detection_noise_params": DETECTION_NOISE, "motion_noise_params": MOTION_NOISE, "lost_params": LOST}


def with_defaults(rows, defaults):
    """`rows` with some defaults of the filter's own ({name: value}); a name not among them is a
    ValueError naming the list's names."""
    names = [row[0] for row in rows]
    unknown = sorted(set(defaults) - set(names))
    if unknown:
        raise ValueError(f"no parameter {unknown[0]!r} here (these are {', '.join(names)})")
    return [(row[0], row[1], defaults.get(row[0], row[2])) + tuple(row[3:]) for row in rows]
