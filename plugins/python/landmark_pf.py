"""A particle filter on landmarks in numpy: `--localizer python:landmark_pf` (docs/python.md)."""
import numpy as np

import locsim


class LandmarkPF(locsim.Localizer):
    """Particle filter on landmarks, in numpy: odometry motion, range-bearing detections."""

    params = [locsim.param("particles", int, 2000, 10, 1_000_000, "particle count [-]"),
              locsim.param("sigma_range_m", float, 0.3, 0.001, 10.0, "range noise of a detection [m]"),
              locsim.param("sigma_bearing_rad", float, 0.1, 0.0001, 1.0, "bearing noise of a detection [rad]"),
              locsim.param("resample_below", float, 0.5, 0.0, 1.0, "resample when N_eff / N drops below it [-]"),
              locsim.param("motion_floor_m", float, 0.005, 0.0, 10.0, "position noise of every step, per axis [m]"),
              locsim.param("motion_floor_deg", float, 0.5, 0.0, 180.0, "heading noise of every step [deg]"),
              locsim.param("outlier_likelihood", float, 0.05, 0.0, 1.0,
                           "added to each detection's likelihood (1: a perfect match): the chance it is false [-]")]

    def __init__(self, init):
        super().__init__(init)
        n, self.rng, self.odom, self.moved_at = init.params["particles"], init.rng, None, None
        if init.initial_pose_known:
            self.x = self.rng.multivariate_normal(init.initial_pose, init.initial_covariance, n)
        else:  # uniform over the free cells of the map, any heading
            self.x = locsim.free_space_poses(init, n, self.rng)
        self.w = np.full(n, 1.0 / n)
        p = init.params  # the alphas of paper 004 and a floor, so that particles never collapse
        self.noise = locsim.OdometryNoise(floor_position_m=p["motion_floor_m"],
                                          floor_heading_rad=np.radians(p["motion_floor_deg"]))

    def on_odometry(self, t_s, odometry):
        self.odom = np.array(odometry.pose)
        if self.moved_at is None:
            self.moved_at = self.odom

    def on_landmarks(self, t_s, landmarks):
        init, p = self.init, self.init.params
        if self.odom is not None:  # the motion since the last step, one noisy sample per particle
            locsim.sample_motion(self.x, locsim.decompose(self.moved_at, self.odom), self.rng, self.noise)
            self.moved_at = self.odom
        log_w, log_outlier = np.log(self.w), np.log(max(p["outlier_likelihood"], 1e-300))
        for det, color in zip(landmarks.detections, landmarks.colors):
            known = init.landmark_ids == det["id"] if det["id"] >= 0 else np.array(init.landmark_colors) == color
            if known.any():  # the best-matching landmark of its id (or colour) explains it, or it is false
                match = locsim.landmark_log_match(self.x, det["range_m"], det["bearing_rad"], init.landmarks[known],
                                                  p["sigma_range_m"], p["sigma_bearing_rad"]).max(axis=1)
                log_w += np.logaddexp(match, log_outlier)
        self.w = locsim.weights_from_log(log_w)
        if locsim.effective_sample_size(self.w) < p["resample_below"] * len(self.w):
            keep = locsim.low_variance_resample(self.w, self.rng)
            self.x, self.w = self.x[keep], np.full(len(keep), 1.0 / len(keep))

    def estimate(self):  # the particles' mean, moved on by the odometry since the last step
        mean, covariance = locsim.mean_and_covariance(self.x, self.w)
        if self.odom is not None:
            mean = locsim.compose(mean, locsim.between(self.moved_at, self.odom))
        return mean, covariance

    def particles(self):
        return self.x, self.w
