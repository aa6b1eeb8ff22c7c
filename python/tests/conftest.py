"""Fixtures: small runs and a small sweep made by the locsim binary under test (LOCSIM_BINARY, set
by ctest; else the build next to the package), once per test session, in a temporary folder."""
import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))  # this tree's package, whatever else is installed

import locsim  # noqa: E402

SOURCE = os.environ.get("LOCSIM_SOURCE_DIR", os.path.normpath(os.path.join(HERE, "..", "..")))
DEMO = os.path.join(SOURCE, "worlds", "demo", "demo.yaml")


@pytest.fixture(scope="session")
def source_dir():
    return SOURCE


@pytest.fixture(scope="session")
def demo_run(tmp_path_factory):
    """The demo world for 24 s (its first kidnap is at 20 s) with three localizers, every sensor
    logged."""
    out = tmp_path_factory.mktemp("runs") / "demo"
    return locsim.run(DEMO, out, localizers=["odometry", "ekf_landmarks", "ultrasonic_amcl"], duration=24,
                      seed=3)


@pytest.fixture(scope="session")
def four_robots(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "four"
    return locsim.run(os.path.join(SOURCE, "worlds", "demo", "four_robots.yaml"), out,
                      localizers=["odometry", "ekf_landmarks"], duration=4)


@pytest.fixture(scope="session")
def small_sweep(tmp_path_factory):
    """Two configurations x 4 seeds of the demo world for 6 s."""
    folder = tmp_path_factory.mktemp("sweep")
    experiment = folder / "small.yaml"
    experiment.write_text(f"""name: small
world: {DEMO}
duration_s: 6
seeds: {{from: 1, to: 4}}
localizers:
  - plugin: odometry
  - plugin: ekf_landmarks
    label: ekf
""")
    return locsim.sweep(experiment, folder / "out", jobs=2)
