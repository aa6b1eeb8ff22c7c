"""Test plugin: at its first odometry reading after 1 s starts a program that outlives it."""
import subprocess

import numpy as np

import locsim


class Popen(locsim.Localizer):
    """Starts `sleep 600` with subprocess.Popen (its stdout and stderr are the plugin's) and
    writes its pid to pid_file (tests: it must not outlive the run)."""

    params = [locsim.param("pid_file", str, "", doc="where to write the program's pid")]

    def __init__(self, init):
        super().__init__(init)
        self.started = False

    def on_odometry(self, t_s, odometry):
        if t_s >= 1.0 and not self.started:
            self.started = True
            child = subprocess.Popen(["sleep", "600"])
            with open(self.init.params["pid_file"], "w") as out:
                out.write(f"{child.pid}\n")

    def estimate(self):
        return self.init.initial_pose, np.eye(3)
