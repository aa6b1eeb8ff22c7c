"""Particle-filter helpers for localizers written in Python: weights, resampling and the
weighted estimate, the C++ SDK's (plugins/sdk/include/locsim/particles.hpp) in numpy.

Particles are an (N, 3) array of poses and an (N,) array of weights; a resampler returns the
chosen indices, so a filter with more per-particle state (a map, a bias) picks it the same way:
    keep = locsim.low_variance_resample(w, rng); x, w = x[keep], np.full(len(keep), 1 / len(keep))
"""

import numpy as np

from .io import wrap_angle


def normalize(w):
    """Weights scaled to sum 1 (a new array); all equal when their sum is 0 or not finite."""
    w = np.asarray(w, dtype=float)
    total = w.sum()
    if not (total > 0.0 and np.isfinite(total)):
        return np.full(len(w), 1.0 / len(w)) if len(w) else w.copy()
    return w / total


def weights_from_log(log_w):
    """Normalised weights from log weights, without underflow: exp(log_w - max), then normalize."""
    log_w = np.asarray(log_w, dtype=float)
    if len(log_w) == 0 or not np.isfinite(log_w.max()):
        return normalize(np.zeros(len(log_w)))
    return normalize(np.exp(log_w - log_w.max()))


def effective_sample_size(w):
    """N_eff = 1 / sum w^2 of normalised weights (0 for no weight)."""
    sq = float(np.dot(w, w))
    return 1.0 / sq if sq > 0.0 else 0.0


def low_variance_resample(w, rng):
    """Low-variance (systematic) resampling: one uniform draw, n evenly spaced pointers along the
    cumulative weights; the chosen indices, ascending."""
    w = np.asarray(w, dtype=float)
    n = len(w)
    if n == 0:
        return np.zeros(0, dtype=np.intp)
    cumulative = np.cumsum(w)
    pointers = (rng.random() + np.arange(n)) * (cumulative[-1] / n)
    return np.minimum(np.searchsorted(cumulative, pointers, side="left"), n - 1)


def roulette_resample(w, rng):
    """Roulette-wheel (multinomial) resampling: n independent draws, particle i with probability
    w_i, drawn already sorted (the normalised partial sums of n + 1 exponentials are n sorted
    uniforms); the chosen indices, ascending."""
    w = np.asarray(w, dtype=float)
    n = len(w)
    if n == 0:
        return np.zeros(0, dtype=np.intp)
    partial = np.cumsum(rng.exponential(1.0, n + 1))
    cumulative = np.cumsum(w)
    u = partial[:n] * (cumulative[-1] / partial[n])
    return np.minimum(np.searchsorted(cumulative, u, side="right"), n - 1)


def circular_mean(theta, w=None):
    """The weighted mean direction of angles [rad]: atan2 of the mean sine and cosine."""
    theta = np.asarray(theta, dtype=float)
    w = np.full(len(theta), 1.0) if w is None else np.asarray(w, dtype=float)
    return float(np.arctan2(w @ np.sin(theta), w @ np.cos(theta)))


def mean_and_covariance(particles, w):
    """The weighted mean pose (circular mean of the headings) and its covariance (3, 3), the
    heading deviations taken about the circular mean: what estimate() returns."""
    p = np.asarray(particles, dtype=float)
    w = np.asarray(w, dtype=float)
    total = w.sum()
    if not total > 0.0:
        total = 1.0
    mean = np.array([w @ p[:, 0] / total, w @ p[:, 1] / total, circular_mean(p[:, 2], w)])
    d = np.column_stack((p[:, 0] - mean[0], p[:, 1] - mean[1], wrap_angle(p[:, 2] - mean[2])))
    return mean, (d * (w / total)[:, None]).T @ d


def free_space_poses(init, n, rng):
    """n poses (n, 3) drawn uniformly over the free cells of the filter's map (init.grid == 0),
    any heading: the start of a global localization, or guesses to inject."""
    free = np.argwhere(init.grid == 0)  # (row, col) of each free cell; row 0 the bottom
    if len(free) == 0:
        raise ValueError("the map has no free cell to draw poses from")
    cells = free[rng.integers(0, len(free), n)]
    xy = (cells[:, ::-1] + rng.random((n, 2))) * init.grid_resolution_m + np.asarray(init.grid_origin)
    return np.column_stack((xy, rng.uniform(-np.pi, np.pi, n)))
