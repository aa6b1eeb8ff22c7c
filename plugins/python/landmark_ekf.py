"""An extended Kalman filter on landmarks in numpy: `--localizer python:landmark_ekf` (docs/python.md)."""
import numpy as np

import locsim


class EkfLandmarks(locsim.Localizer):
    """EKF on landmarks, in numpy: wheel-travel prediction, range-bearing updates of known ids."""
    # Rejecting more than it accepts, it is lost (a push its wheels did not feel, a kidnap): the
    # SDK's LostWatch widens its covariance until the landmarks fit again (lost_*, as the C++
    # ekf_landmarks').

    # The wheel and detection noise under the built-in filters' names, so that the file
    # `locsim calibrate` writes sets this filter too.
    params = ([locsim.param("k_left", float, 0.0013, 0.0, 1.0, "left wheel random error [m^1/2]"),
               locsim.param("k_right", float, 0.0012, 0.0, 1.0, "right wheel random error [m^1/2]"),
               locsim.param("gate", float, 13.8, 0.0, 1e9, "chi-square (2 dof) beyond which a detection is an outlier [-]")]
              # Looser than the C++ filters' defaults: this example has no gyro, and with their
              # noise its heading NEES is tens on the demo.
              + locsim.detection_noise_params(sigma_range_m=0.3, sigma_range_per_m2=0.0, sigma_bearing_deg=5.73)
              + locsim.lost_params())

    def __init__(self, init):
        super().__init__(init)
        self.x, self.P = np.array(init.initial_pose, dtype=float), np.array(init.initial_covariance, dtype=float)
        self.odom, self.rejected = None, 0
        self.landmark_at = {int(i): xy for i, xy in zip(init.landmark_ids, np.array(init.landmarks))}
        self.detection = locsim.DetectionNoise.from_params(init.params)
        self.lost = locsim.LostWatch.from_params(init.params)

    def on_odometry(self, t_s, odometry):  # x' = f(x, u), P' = F P F^T + G Q G^T
        pose, p = np.array(odometry.pose), self.init.params
        if self.odom is not None:
            d_left, d_right = locsim.wheel_travel_from_increment(locsim.between(self.odom, pose), self.init.wheel_base_m)
            self.x, self.P = locsim.predict_by_wheels(self.x, self.P, d_left, d_right, self.init.wheel_base_m,
                                                      p["k_left"], p["k_right"])
        self.odom = pose

    def on_landmarks(self, t_s, landmarks):  # one update per detection of a mapped id
        p = self.init.params
        for det in landmarks.detections:
            if int(det["id"]) not in self.landmark_at:
                continue
            R = np.diag([self.detection.sigma_range(det["range_m"]) ** 2, self.detection.sigma_bearing_rad ** 2])
            z_hat, H = locsim.range_bearing(self.x, self.landmark_at[int(det["id"])], jacobian=True)
            nu = np.array([det["range_m"] - z_hat[0], locsim.wrap_angle(det["bearing_rad"] - z_hat[1])])
            S = H @ self.P @ H.T + R
            if nu @ np.linalg.solve(S, nu) > p["gate"]:
                self.rejected += 1
                self.lost.rejected(t_s, self.P)
                continue
            self.lost.accepted()
            K = self.P @ H.T @ np.linalg.inv(S)
            self.x = self.x + K @ nu
            self.x[2] = locsim.wrap_angle(self.x[2])
            I_KH = np.eye(3) - K @ H  # Joseph form: P stays symmetric and positive definite
            self.P = I_KH @ self.P @ I_KH.T + K @ R @ K.T

    def estimate(self):
        return self.x, self.P

    def diagnostics(self):
        return {"rejected": self.rejected, "times_lost": self.lost.times_lost}
