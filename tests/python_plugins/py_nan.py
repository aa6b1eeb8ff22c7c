"""Test plugin: its estimate turns NaN after 1 s."""
import math

import numpy as np

import locsim


class Nan(locsim.Localizer):
    """Returns a NaN pose after 1 s (tests)."""

    def __init__(self, init):
        super().__init__(init)
        self.t_s = 0.0

    def on_odometry(self, t_s, odometry):
        self.t_s = t_s

    def estimate(self):
        pose = np.array(self.init.initial_pose)
        if self.t_s > 1.0:
            pose[0] = math.nan
        return pose, np.eye(3)
