"""Filter maths for localizers written in Python: the C++ SDK's models (plugins/sdk/include/locsim/
models.hpp and particles.hpp) in numpy, vectorised over particles. The same equations, the same
names and the same defaults, so a filter moves between the languages without its numbers moving
(tests/python_sdk_test.cpp checks each function against its C++ twin).

Poses are arrays whose last axis is (x [m], y [m], theta [rad]): one pose (3,) or particles (N, 3).
Functions that take Jacobians return them when asked (`jacobians=True`); tests check each against
finite differences (`numeric_jacobian`).
"""

import math
from dataclasses import dataclass

import numpy as np

from .io import wrap_angle
from . import noise_params
from .noise_params import K_LEFT, K_RIGHT  # noqa: F401  (locsim.K_LEFT)
from .plugin import param


def _pose(x):
    return np.asarray(x, dtype=float)


def numeric_jacobian(f, x, step=1e-6):
    """d f / d x by central differences (angles in f's output wrapped by the caller): the check of
    every analytic Jacobian here, and of a filter's own."""
    x = _pose(x)
    f0 = np.atleast_1d(f(x))
    J = np.empty((f0.size, x.size))
    for i in range(x.size):
        dx = np.zeros_like(x)
        dx.flat[i] = step
        J[:, i] = (np.atleast_1d(f(x + dx)) - np.atleast_1d(f(x - dx))).ravel() / (2 * step)
    return J


# ---------------------------------------------------------------------------------------------
# Poses

def compose(a, b):
    """a (+) b: pose b, given in a's frame, in a's parent frame."""
    a, b = _pose(a), _pose(b)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack((a[..., 0] + c * b[..., 0] - s * b[..., 1],
                     a[..., 1] + s * b[..., 0] + c * b[..., 1],
                     wrap_angle(a[..., 2] + b[..., 2])), axis=-1)


def between(a, b):
    """The pose of b in a's frame: a^-1 (+) b (an odometry increment from two odometry poses)."""
    a, b = _pose(a), _pose(b)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
    return np.stack((c * dx + s * dy, -s * dx + c * dy, wrap_angle(b[..., 2] - a[..., 2])), axis=-1)


def sinc(x):
    """sin(x) / x, its Taylor series 1 - x^2/6 below |x| = 1e-4 where the quotient loses
    precision (numpy's np.sinc is another function: sin(pi x) / (pi x))."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < 1e-4
    return np.where(small, 1.0 - x * x / 6.0, np.sin(x) / np.where(small, 1.0, x))


def advance_by_velocity(x, v_mps, omega_radps, dt_s):
    """The pose reached from x driving at v [m/s] and omega [rad/s] for dt [s]: an exact arc, its
    chord v dt sinc(omega dt / 2) along the mid-heading (a straight line when omega = 0)."""
    x = _pose(x)
    turn = omega_radps * dt_s
    chord = v_mps * dt_s * sinc(0.5 * turn)
    heading = x[..., 2] + 0.5 * turn
    return np.stack((x[..., 0] + chord * np.cos(heading), x[..., 1] + chord * np.sin(heading),
                     wrap_angle(x[..., 2] + turn)), axis=-1)


# ---------------------------------------------------------------------------------------------
# Differential drive by the wheels (paper 002)

def diff_drive_motion(x, d_left_m, d_right_m, wheel_base_m, jacobians=False):
    """Dead reckoning over one step of wheel travel, on the mid-heading:
        D = (dl + dr) / 2, a = (dr - dl) / b,
        x' = x + D cos(theta + a/2), y' = y + D sin(theta + a/2), theta' = theta + a.
    x may be particles (N, 3) with per-particle travel (N,). With jacobians=True (one pose):
    (x', F = dx'/dx (3x3), G = dx'/d(dl, dr) (3x2))."""
    x = _pose(x)
    D = 0.5 * (d_left_m + d_right_m)
    a = (d_right_m - d_left_m) / wheel_base_m
    heading = x[..., 2] + 0.5 * a
    c, s = np.cos(heading), np.sin(heading)
    moved = np.stack((x[..., 0] + D * c, x[..., 1] + D * s, wrap_angle(x[..., 2] + a)), axis=-1)
    if not jacobians:
        return moved
    F = np.array([[1.0, 0.0, -D * s], [0.0, 1.0, D * c], [0.0, 0.0, 1.0]])
    k = 0.5 * D / wheel_base_m
    G = np.array([[0.5 * c + k * s, 0.5 * c - k * s],
                  [0.5 * s - k * c, 0.5 * s + k * c],
                  [-1.0 / wheel_base_m, 1.0 / wheel_base_m]])
    return moved, F, G


def wheel_travel_from_increment(delta, wheel_base_m):
    """The wheel travel (left, right) [m] that moves a differential drive by the pose increment
    `delta` (as between() gives it), taken as one arc: ds = chord / sinc(turn / 2), signed by the
    chord's direction along the mid-heading, left = ds - b turn / 2, right = ds + b turn / 2."""
    dx, dy, turn = (float(v) for v in delta)
    chord = math.hypot(dx, dy)
    along = dx * math.cos(0.5 * turn) + dy * math.sin(0.5 * turn)
    ds = (-chord if along < 0.0 else chord) / float(sinc(0.5 * turn))
    return ds - 0.5 * wheel_base_m * turn, ds + 0.5 * wheel_base_m * turn




def predict_by_wheels(x, P, d_left_m, d_right_m, wheel_base_m, k_left=K_LEFT, k_right=K_RIGHT,
                      slip_m=0.0):
    """Kalman prediction by one step of wheel travel with paper 002's input noise
    Q = diag(k_l^2 |dl| + slip^2, k_r^2 |dr| + slip^2):  x' = f(x, u),  P' = F P F^T + G Q G^T."""
    moved, F, G = diff_drive_motion(x, d_left_m, d_right_m, wheel_base_m, jacobians=True)
    Q = np.diag([k_left ** 2 * abs(d_left_m) + slip_m ** 2, k_right ** 2 * abs(d_right_m) + slip_m ** 2])
    return moved, F @ P @ F.T + G @ Q @ G.T


# ---------------------------------------------------------------------------------------------
# Odometry by rotate-translate-rotate (Probabilistic Robotics 5.4; SPEC section 2)

@dataclass
class OdometryNoise:
    """The motion model's alpha_1..alpha_4 (defaults from paper 004, as the C++ SDK's)."""

    alpha1: float = 0.0014    # rotation noise from rotation
    alpha2: float = 0.000125  # rotation noise from translation
    alpha3: float = 0.01      # translation noise from translation
    alpha4: float = 0.26      # translation noise from rotation
    variance_form: bool = False  # True: Thrun's variance b = alpha u^2 + alpha v^2
    # Noise every step has whatever its motion (real robots creep, odometry has timing errors;
    # without it particles driving straight collapse onto one): deviations added after the motion
    # to x and y [m] and to the heading [rad]. 0: none, and no random draws for it.
    floor_position_m: float = 0.0
    floor_heading_rad: float = 0.0


    @classmethod
    def from_params(cls, params):
        """From a filter's parameters as motion_noise_params() declares them (the floor's heading
        in degrees, as the C++ SDK's and `locsim calibrate`'s). The floor is the robot's and the
        filter's roughening together, in quadrature, as the C++ landmark particle filters add them."""
        return cls(params["alpha1"], params["alpha2"], params["alpha3"], params["alpha4"],
                   bool(params["variance_form"]),
                   math.hypot(params["motion_floor_m"], params["roughening_m"]),
                   math.radians(math.hypot(params["motion_floor_deg"], params["roughening_deg"])))


def motion_noise_params(**defaults):
    """The motion model's parameters as the C++ landmark particle filters declare them (names,
    defaults, ranges: noise_params.py), so that one parameter file (the one `locsim calibrate`
    writes) sets a Python filter as it sets the built-in ones: motion_model `odometry`
    (alpha1..alpha4, variance_form) or `wheels` (k_left, k_right), and the floor every step has
    whatever its motion. A filter's `params` may add the call: `[...] + locsim.motion_noise_params()`."""
    return [param(*row) for row in noise_params.with_defaults(noise_params.MOTION_NOISE, defaults)]


def decompose(from_pose, to_pose):
    """(rot1, trans, rot2) of the motion between two odometry poses; below a millimetre the
    direction of travel is noise and the motion a pure rotation."""
    a, b = _pose(from_pose), _pose(to_pose)
    dx, dy = b[0] - a[0], b[1] - a[1]
    trans = math.hypot(dx, dy)
    rot1 = 0.0 if trans < 1e-3 else float(wrap_angle(math.atan2(dy, dx) - a[2]))
    return rot1, trans, float(wrap_angle(b[2] - a[2] - rot1))


def motion_spread(delta, noise=OdometryNoise(), slip_rad=0.0):
    """The standard deviations (rot1, trans, rot2) of the noise on each part of `delta`:
        rot1: a1 |rot1| + a2 trans,  trans: a4 (|rot1 + rot2| + slip) + a3 trans,  rot2 likewise;
    each rotation counted as min(|rot|, pi - |rot|) so that reversing is as noisy as driving."""
    rot1, trans, rot2 = delta

    def spread(a, u, b, v):
        return math.sqrt(a * u * u + b * v * v) if noise.variance_form else a * abs(u) + b * abs(v)

    def turned(rot):
        return min(abs(rot), math.pi - abs(rot))

    return (spread(noise.alpha1, turned(rot1), noise.alpha2, trans),
            spread(noise.alpha4, abs(float(wrap_angle(rot1 + rot2))) + slip_rad, noise.alpha3, trans),
            spread(noise.alpha1, turned(rot2), noise.alpha2, trans))


def sample_motion(particles, delta, rng, noise=OdometryNoise(), slip_rad=0.0):
    """Moves every particle (N, 3), in place, by its own noisy sample of `delta` (the paper's
    sample_motion_model_odometry); returns them."""
    n = len(particles)
    s = motion_spread(delta, noise, slip_rad)
    rot1 = delta[0] + rng.normal(0.0, 1.0, n) * s[0]
    trans = delta[1] + rng.normal(0.0, 1.0, n) * s[1]
    rot2 = delta[2] + rng.normal(0.0, 1.0, n) * s[2]
    heading = particles[:, 2] + rot1
    particles[:, 0] += trans * np.cos(heading)
    particles[:, 1] += trans * np.sin(heading)
    particles[:, 2] = wrap_angle(heading + rot2)
    return add_motion_floor(particles, rng, noise)


def add_motion_floor(particles, rng, noise):
    """Adds the noise every step has whatever its motion (OdometryNoise.floor_*), in place."""
    n = len(particles)
    if noise.floor_position_m > 0.0:
        particles[:, :2] += rng.normal(0.0, noise.floor_position_m, (n, 2))
    if noise.floor_heading_rad > 0.0:
        particles[:, 2] = wrap_angle(particles[:, 2] + rng.normal(0.0, noise.floor_heading_rad, n))
    return particles


def sample_wheel_motion(particles, d_left_m, d_right_m, wheel_base_m, rng, k_left=K_LEFT,
                        k_right=K_RIGHT, slip_m=0.0):
    """Moves every particle (N, 3), in place, by its own noisy sample of one step of wheel travel:
    each wheel's travel drawn with variance k^2 |d| (+ slip^2), then diff_drive_motion."""
    def spread(k, d):
        return k * math.sqrt(abs(d)) if slip_m == 0.0 else math.sqrt(k * k * abs(d) + slip_m * slip_m)

    n = len(particles)
    dl = d_left_m + rng.normal(0.0, 1.0, n) * spread(k_left, d_left_m)
    dr = d_right_m + rng.normal(0.0, 1.0, n) * spread(k_right, d_right_m)
    particles[:] = diff_drive_motion(particles, dl, dr, wheel_base_m)
    return particles


# ---------------------------------------------------------------------------------------------
# Landmarks

def range_bearing(x, landmark, jacobian=False):
    """Range and bearing from pose x to a point landmark (x, y):
        r = |m - p|,  phi = atan2(my - y, mx - x) - theta;   H = d(r, phi)/dx (2x3) when asked."""
    x, m = _pose(x), np.asarray(landmark, dtype=float)
    dx, dy = m[0] - x[..., 0], m[1] - x[..., 1]
    q = dx * dx + dy * dy
    r = np.sqrt(q)
    z = np.stack((r, wrap_angle(np.arctan2(dy, dx) - x[..., 2])), axis=-1)
    if not jacobian:
        return z
    H = np.array([[-dx / r, -dy / r, 0.0], [dy / q, -dx / q, -1.0]])
    return z, H


@dataclass
class DetectionNoise:
    """How noisy a PTZ or range-bearing detection is at the range it measured (the C++ SDK's
    DetectionNoise; the defaults fit locsim's PTZ camera at 160 x 120):
        sigma_range(r) = sigma_range_m + (sigma_range_per_m + sigma_range_per_m2 r) r."""

    sigma_range_m: float = 0.02        # at zero range [m]
    sigma_range_per_m: float = 0.0     # growth with the range [m/m]
    sigma_range_per_m2: float = 0.015  # growth with the range's square [1/m]
    sigma_bearing_rad: float = 0.026   # bearing [rad]

    @classmethod
    def from_params(cls, params):
        """From a filter's parameters as detection_noise_params() declares them."""
        return cls(params["sigma_range_m"], params["sigma_range_per_m"], params["sigma_range_per_m2"],
                   math.radians(params["sigma_bearing_deg"]))

    def sigma_range(self, range_m):
        return self.sigma_range_m + (self.sigma_range_per_m + self.sigma_range_per_m2 * range_m) * range_m


def detection_noise_params(**defaults):
    """The detection noise's parameters as ekf_landmarks and the landmark particle filters declare
    them (names, defaults, ranges, the bearing in degrees: noise_params.py), so that
    `locsim calibrate`'s file sets a Python filter as it sets the built-in ones. A filter's `params`
    may add the call: `[...] + locsim.detection_noise_params()`, with defaults of its own as
    keywords (`sigma_bearing_deg=5.0`)."""
    return [param(*row) for row in noise_params.with_defaults(noise_params.DETECTION_NOISE, defaults)]


class LostWatch:
    """Whether a filter with a gate is lost, and its covariance widened while it is (the C++ SDK's
    LostWatch): a running count of the rejections in excess of the acceptances (+1, -1, never
    below 0); while it is at least after_rejections, each rejection widens P's pose block (its
    first three rows and columns) as a random walk of growth_m and growth_rad per root second over
    the time since the count left 0, then since the last widening, up to max_m / max_rad, never
    narrowing it."""

    def __init__(self, after_rejections=12, growth_m=0.5, growth_rad=math.radians(20.0), max_m=3.0,
                 max_rad=math.radians(60.0)):
        self.after_rejections, self.growth_m, self.growth_rad = after_rejections, growth_m, growth_rad
        self.max_m, self.max_rad = max_m, max_rad
        self.excess, self.times_lost, self._was_lost, self._widened_s = 0, 0, False, 0.0

    @classmethod
    def from_params(cls, params):
        """From a filter's parameters as lost_params() declares them (the heading in degrees)."""
        return cls(int(params["lost_after_rejections"]), params["lost_growth_m"],
                   math.radians(params["lost_growth_deg"]), params["lost_max_m"], math.radians(params["lost_max_deg"]))

    @property
    def lost(self):
        return self.after_rejections > 0 and self.excess >= self.after_rejections

    def accepted(self):
        """A detection the filter took."""
        self.excess = max(0, self.excess - 1)
        if not self.lost:
            self._was_lost = False

    def rejected(self, t_s, P):
        """A detection of a known target the filter rejected at t_s [s]; when that says lost, P's
        pose block is widened in place. True if it was."""
        if self.after_rejections <= 0:
            return False
        if self.excess == 0:
            self._widened_s = t_s
        self.excess += 1
        if not self.lost:
            return False
        if not self._was_lost:
            self.times_lost, self._was_lost = self.times_lost + 1, True
        dt_s = max(0.0, t_s - self._widened_s)
        self._widened_s = t_s
        for i, (limit, growth) in enumerate(((self.max_m, self.growth_m), (self.max_m, self.growth_m),
                                             (self.max_rad, self.growth_rad))):
            room = limit * limit - P[i, i]
            if room > 0.0:
                P[i, i] += min(growth * growth * dt_s, room)
        return True


def lost_params(**defaults):
    """LostWatch's parameters as ekf_landmarks declares them (noise_params.py), so that a Python
    filter with a gate takes the same keys: `[...] + locsim.lost_params()`."""
    return [param(*row) for row in noise_params.with_defaults(noise_params.LOST, defaults)]


def landmark_log_match(particles, range_m, bearing_rad, landmarks, sigma_range_m, sigma_bearing_rad):
    """log of the landmark likelihood scaled to 1 at a perfect match, for every particle (N, 3)
    and landmark (K, 2) at once, (N, K):
        -e_r^2 / (2 sigma_r^2) - (1 - cos e_phi) / sigma_phi^2,
    the bearing term a von Mises density (periodic, no wrapping; within 1 % of the Gaussian's up
    to 14 degrees of error), cos e_phi from a dot product rather than an atan2."""
    p = _pose(particles).reshape(-1, 3)
    m = np.asarray(landmarks, dtype=float).reshape(-1, 2)
    dx = m[None, :, 0] - p[:, 0:1]
    dy = m[None, :, 1] - p[:, 1:2]
    r = np.hypot(dx, dy)
    heading = p[:, 2:3] + bearing_rad
    cos_error = (np.cos(heading) * dx + np.sin(heading) * dy) / np.maximum(r, 1e-300)
    er = (range_m - r) / sigma_range_m
    return -0.5 * er * er - (1.0 - cos_error) / (sigma_bearing_rad * sigma_bearing_rad)


def von_mises_log_normaliser_excess(sigma):
    """log of the von Mises normaliser relative to the Gaussian's (k = 1 / sigma^2): the constant
    that turns landmark_log_match into a log density (tends to 0 as sigma shrinks)."""
    k = 1.0 / (sigma * sigma)
    if k < 15.0:
        term = total = 1.0
        for j in range(1, 80):
            term *= 0.25 * k * k / (j * j)
            total += term
        log_scaled_i0 = math.log(total) - k
    else:
        log_scaled_i0 = (-0.5 * math.log(2 * math.pi * k)
                         + math.log1p(1 / (8 * k) + 9 / (128 * k * k) + 225 / (3072 * k ** 3)))
    return math.log(2 * math.pi) + log_scaled_i0 - 0.5 * math.log(2 * math.pi / k)


def landmark_log_likelihood(particles, range_m, bearing_rad, landmarks, sigma_range_m, sigma_bearing_rad):
    """log p(z | x, m) of one range-bearing detection, (N, K): a normal density on the range times
    the von Mises density on the bearing. Sum over a step's detections, then one exp."""
    return (landmark_log_match(particles, range_m, bearing_rad, landmarks, sigma_range_m, sigma_bearing_rad)
            - math.log(2 * math.pi * sigma_range_m * sigma_bearing_rad)
            - von_mises_log_normaliser_excess(sigma_bearing_rad))
