"""A particle filter on landmarks in numpy: `--localizer python:landmark_pf` (docs/python.md)."""
import numpy as np

import locsim


class LandmarkPF(locsim.Localizer):
    """Particle filter on landmarks, in numpy: odometry motion, range-bearing detections."""

    # The motion and detection noise under the built-in filters' names, so that the file
    # `locsim calibrate` writes sets this filter too.
    params = ([locsim.param("particles", int, 2000, 10, 1_000_000, "particle count [-]"),
               locsim.param("resample_below", float, 0.5, 0.0, 1.0, "resample when N_eff / N drops below it [-]"),
               locsim.param("outlier_likelihood", float, 0.05, 0.0, 1.0,
                            "added to each detection's likelihood (1: a perfect match): the chance it is false [-]")]
              + locsim.motion_noise_params() + locsim.detection_noise_params())

    def __init__(self, init):
        super().__init__(init)
        p = init.params
        if p["motion_model"] not in ("odometry", "wheels"):
            raise ValueError(f"motion_model must be odometry or wheels, not {p['motion_model']!r}")
        n, self.rng, self.odom, self.moved_at = p["particles"], init.rng, None, None
        if init.initial_pose_known:
            self.x = self.rng.multivariate_normal(init.initial_pose, init.initial_covariance, n)
        else:  # uniform over the free cells of the map, any heading
            self.x = locsim.free_space_poses(init, n, self.rng)
        self.w = np.full(n, 1.0 / n)
        self.noise = locsim.OdometryNoise.from_params(p)
        self.detection = locsim.DetectionNoise.from_params(p)
        self.travel = np.zeros(2)  # |wheel travel| since the last step, left and right [m]

    def on_odometry(self, t_s, odometry):
        pose = np.array(odometry.pose)
        if self.odom is not None:  # the wheel model's variance adds up k^2 |d| reading by reading
            step = locsim.wheel_travel_from_increment(locsim.between(self.odom, pose), self.init.wheel_base_m)
            self.travel += np.abs(step)
        self.odom = pose
        if self.moved_at is None:
            self.moved_at = self.odom

    def move(self):
        """The motion since the last step, one noisy sample per particle."""
        p = self.init.params
        delta = locsim.between(self.moved_at, self.odom)
        if p["motion_model"] == "odometry":
            locsim.sample_motion(self.x, locsim.decompose(self.moved_at, self.odom), self.rng, self.noise)
        else:  # the whole step's wheel travel, each wheel's noise from the travel read by read
            d_left, d_right = locsim.wheel_travel_from_increment(delta, self.init.wheel_base_m)
            spread = np.array([p["k_left"], p["k_right"]]) * np.sqrt(self.travel)
            n = len(self.x)
            dl = d_left + self.rng.normal(0.0, 1.0, n) * spread[0]
            dr = d_right + self.rng.normal(0.0, 1.0, n) * spread[1]
            self.x[:] = locsim.diff_drive_motion(self.x, dl, dr, self.init.wheel_base_m)
            locsim.add_motion_floor(self.x, self.rng, self.noise)
        self.moved_at, self.travel = self.odom, np.zeros(2)

    def on_landmarks(self, t_s, landmarks):
        init, p = self.init, self.init.params
        if self.odom is not None:
            self.move()
        log_w, log_outlier = np.log(self.w), np.log(max(p["outlier_likelihood"], 1e-300))
        for det, color in zip(landmarks.detections, landmarks.colors):
            known = init.landmark_ids == det["id"] if det["id"] >= 0 else np.array(init.landmark_colors) == color
            if known.any():  # the best-matching landmark of its id (or colour) explains it, or it is false
                match = locsim.landmark_log_match(self.x, det["range_m"], det["bearing_rad"], init.landmarks[known],
                                                  self.detection.sigma_range(det["range_m"]),
                                                  self.detection.sigma_bearing_rad).max(axis=1)
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
