"""Test plugin: handles every kind of reading and does nothing (the host's own cost per reading)."""
import numpy as np

import locsim


class Noop(locsim.Localizer):
    """Does nothing with every reading (tests, benchmarks)."""

    def on_odometry(self, t_s, odometry):
        pass

    def on_imu(self, t_s, imu):
        pass

    def on_landmarks(self, t_s, landmarks):
        pass

    def on_beacon_ranges(self, t_s, ranges):
        pass

    def on_laser(self, t_s, scan):
        pass

    def estimate(self):
        return self.init.initial_pose, np.eye(3)
