"""Test plugin: raises from its landmark handler at the first detection after 1 s."""
import numpy as np

import locsim


class Raises(locsim.Localizer):
    """Raises ValueError on a landmark reading after 1 s (tests)."""

    def on_landmarks(self, t_s, landmarks):
        if t_s > 1.0 and len(landmarks) > 0:
            raise ValueError(f"a deliberate failure at {t_s:.1f} s")

    def estimate(self):
        return self.init.initial_pose, np.eye(3)
