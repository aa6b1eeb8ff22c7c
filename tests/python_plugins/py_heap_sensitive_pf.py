"""A numpy particle filter whose results, without the python plugin's aligned allocator, change with
what else the process allocated (--log, --isolation none): its arctan2, exp and sums on small and
broadcast arrays take numpy's SIMD or scalar loops by where the arrays lie. Kept as it was when the
fresh-clone CI found this (tests/python_plugin_test.cpp, ResultsDoNotDependOnTheHeap)."""
import numpy as np

import locsim


class HeapSensitivePF(locsim.Localizer):
    """Particle filter on landmarks, in numpy: odometry motion, range-bearing detections."""

    params = [locsim.param("particles", int, 2000, 10, 1_000_000, "particle count [-]"),
              locsim.param("alpha", float, 0.1, 0.0, 2.0, "odometry noise per metre or radian moved [-]"),
              locsim.param("sigma_range_m", float, 0.3, 0.001, 10.0, "range noise of a detection [m]"),
              locsim.param("sigma_bearing_rad", float, 0.1, 0.0001, 1.0, "bearing noise of a detection [rad]")]

    def __init__(self, init):
        super().__init__(init)
        n, self.rng, self.odom = init.params["particles"], init.rng, None
        if init.initial_pose_known:
            self.x = self.rng.multivariate_normal(init.initial_pose, init.initial_covariance, n)
        else:  # uniform over the free cells of the map, any heading
            cells = np.argwhere(init.grid == 0)[self.rng.integers(0, int((init.grid == 0).sum()), n)]
            xy = (cells[:, ::-1] + self.rng.random((n, 2))) * init.grid_resolution_m + init.grid_origin
            self.x = np.column_stack((xy, self.rng.uniform(-np.pi, np.pi, n)))
        self.w = np.full(n, 1.0 / n)

    def on_odometry(self, t_s, odometry):
        pose = np.array(odometry.pose)
        if self.odom is not None:  # the move in the last odometry pose's frame, applied to each particle
            d, c, s = pose - self.odom, np.cos(self.odom[2]), np.sin(self.odom[2])
            forward, left, turn = c * d[0] + s * d[1], -s * d[0] + c * d[1], locsim.wrap_angle(d[2])
            sd = self.init.params["alpha"] * (np.hypot(forward, left) + abs(turn)) + 1e-9
            n, theta = len(self.x), self.x[:, 2]
            f, lt = forward + self.rng.normal(0, sd, n), left + self.rng.normal(0, sd, n)
            self.x[:, 0] += np.cos(theta) * f - np.sin(theta) * lt
            self.x[:, 1] += np.sin(theta) * f + np.cos(theta) * lt
            self.x[:, 2] = locsim.wrap_angle(theta + turn + self.rng.normal(0, sd, n))
        self.odom = pose

    def on_landmarks(self, t_s, landmarks):
        init, p = self.init, self.init.params
        log_w = np.log(self.w)
        for det, color in zip(landmarks.detections, landmarks.colors):
            known = init.landmark_ids == det["id"] if det["id"] >= 0 else np.array(init.landmark_colors) == color
            if not known.any():
                continue  # a phantom of a colour no landmark has
            dx = init.landmarks[known, 0][None, :] - self.x[:, 0:1]  # particles x candidate landmarks
            dy = init.landmarks[known, 1][None, :] - self.x[:, 1:2]
            er = (det["range_m"] - np.hypot(dx, dy)) / p["sigma_range_m"]
            eb = locsim.wrap_angle(np.arctan2(dy, dx) - self.x[:, 2:3] - det["bearing_rad"]) / p["sigma_bearing_rad"]
            log_w += np.max(-0.5 * (er * er + eb * eb), axis=1)  # the best-matching landmark
        w = np.exp(log_w - log_w.max())
        self.w = w / w.sum()
        if 1.0 / np.sum(self.w ** 2) < 0.5 * len(self.w):  # low-variance resampling
            n = len(self.w)
            picks = np.searchsorted(np.cumsum(self.w), (self.rng.random() + np.arange(n)) / n)
            self.x, self.w = self.x[np.minimum(picks, n - 1)], np.full(n, 1.0 / n)

    def estimate(self):
        mean = self.w @ self.x[:, :2]
        theta = np.arctan2(self.w @ np.sin(self.x[:, 2]), self.w @ np.cos(self.x[:, 2]))
        d = np.column_stack((self.x[:, :2] - mean, locsim.wrap_angle(self.x[:, 2] - theta)))
        return np.append(mean, theta), (d * self.w[:, None]).T @ d

    def particles(self):
        return self.x, self.w
