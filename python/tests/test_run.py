"""locsim.load_run and its tables against the files and metrics the binary wrote."""
import math
import os
import subprocess
import sys

import numpy as np
import pytest

import locsim


def test_errors_match_metrics(demo_run):
    r = locsim.load_run(demo_run.path)
    assert r.status == "completed" and r.seed == 3 and r.robots == ["robot"]
    assert r.labels() == ["odometry", "ekf_landmarks", "ultrasonic_amcl"]
    errors = r.errors()
    assert set(errors.columns) >= {"robot", "label", "t_s", "dx_m", "dy_m", "position_error_m", "heading_error_rad"}
    for label in r.labels():
        m = r.localizer_metrics(label)
        e = errors[errors.label == label]
        assert len(e) == m["samples"]
        # TUM files hold 6 decimals: the RMS from them equals the scorer's to about 1e-6.
        assert locsim.run_folder.rms(e.position_error_m) == pytest.approx(m["position_error_m"]["rms"], abs=2e-6)
        assert e.position_error_m.max() == pytest.approx(m["position_error_m"]["max"], abs=2e-6)
        heading_rms_deg = math.degrees(locsim.run_folder.rms(e.heading_error_rad))
        assert heading_rms_deg == pytest.approx(m["heading_error_deg"]["rms"], abs=1e-3)
        assert np.all(np.abs(e.heading_error_rad) <= math.pi)


def test_summary_and_trajectories(demo_run):
    s = demo_run.summary().set_index("label")
    assert list(s.index) == demo_run.labels()
    assert (s.status == "ok").all()
    for label in demo_run.labels():
        assert s.loc[label, "position_rms_m"] == demo_run.localizer_metrics(label)["position_error_m"]["rms"]
    truth = demo_run.groundtruth()
    assert list(truth.columns) == ["t_s", "x_m", "y_m", "theta_rad"]
    # 50 Hz ground truth, no rows while the robot is carried (from the kidnap at 20 s).
    assert truth.t_s.iloc[0] == 0.0 and np.allclose(np.diff(truth.t_s[:100]), 0.02)
    assert demo_run.kidnap_times() == [20.0]
    assert not ((truth.t_s > 20.0) & (truth.t_s < 22.0)).any()
    estimate = demo_run.estimate("ekf_landmarks")
    assert len(estimate) == len(truth)


def test_readings(demo_run):
    laser = demo_run.readings("laser")
    beams = demo_run.sensors()["laser"]["beams"]
    assert laser.ranges_m.shape == (len(laser.t_s), beams) and laser.angles_rad.shape == (beams,)
    assert laser.ranges_m.dtype == np.float32
    # 10 Hz, and nothing while the robot is carried (20 to 22 s).
    steps = np.diff(laser.t_s)
    assert np.allclose(steps[laser.t_s[1:] <= 20.0], 0.1) and not ((laser.t_s > 20.0) & (laser.t_s < 22.0)).any()
    encoders = demo_run.readings("encoders")
    assert {"t_s", "left_ticks", "right_ticks", "odom_x_m"} <= set(encoders.columns)
    with pytest.raises(FileNotFoundError, match="readings here"):
        demo_run.readings("sonar")


def test_several_robots(four_robots):
    r = four_robots
    assert r.robots == ["r1", "r2", "r3", "r4"]
    with pytest.raises(ValueError, match="name one"):
        r.labels()
    errors = r.errors()
    assert sorted(set(errors.robot)) == r.robots
    for robot in r.robots:
        m = r.localizer_metrics("ekf_landmarks", robot=robot)
        e = errors[(errors.robot == robot) & (errors.label == "ekf_landmarks")]
        assert locsim.run_folder.rms(e.position_error_m) == pytest.approx(m["position_error_m"]["rms"], abs=2e-6)
    assert len(r.summary()) == 8


def test_not_a_run_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="not a run folder"):
        locsim.load_run(tmp_path)


def test_binary_errors_are_exceptions(tmp_path):
    with pytest.raises(locsim.LocsimError) as error:
        locsim.run(tmp_path / "missing.yaml", tmp_path / "out")
    assert error.value.code == 2 and "missing.yaml" in str(error.value)


def test_acceptance_one_liner(demo_run):
    """The README's promise: after set-up, python3 -c "import locsim; ..." prints a run's errors."""
    code = f"import locsim; r = locsim.load_run({demo_run.path!r}); print(r.errors())"
    env = dict(os.environ, PYTHONPATH=os.path.join(os.path.dirname(__file__), ".."))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    assert "position_error_m" in out and "ultrasonic_amcl" in out
