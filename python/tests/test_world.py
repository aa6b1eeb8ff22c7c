"""locsim.World: the simulation stepped from Python is `locsim run`'s, step for step; readings,
events and commands come through."""
import json
import os

import numpy as np
import pytest

import locsim

SOURCE = os.environ.get("LOCSIM_SOURCE_DIR") or os.path.join(os.path.dirname(__file__), "..", "..")
DEMO = os.path.join(SOURCE, "worlds", "demo", "demo.yaml")


def test_stepped_to_the_end_it_is_the_runs_world(tmp_path):
    run = locsim.run(DEMO, tmp_path / "run", duration=3, seed=4, localizers=[])
    w = locsim.World(DEMO, seed=4, duration=3)
    steps = 0
    while not w.done:
        steps += w.step(50)
    assert steps == w.end_step == w.step_index
    assert f"{w.state_hash():016x}" == json.load(open(tmp_path / "run" / "run.json"))["state_hash"]
    last = run.truth()[-1]  # groundtruth.tum's last row, at the end, to its 6 decimals
    assert last[0] == pytest.approx(w.time_s)
    np.testing.assert_allclose(w.truth()[0], last[1:], atol=2e-6)


def test_readings_events_and_time(tmp_path):
    w = locsim.World(DEMO, seed=2)
    assert w.robots and w.name and w.dt_s > 0 and w.time_s == 0.0
    assert w.run_until(1.0) == round(1.0 / w.dt_s)
    assert w.time_s == pytest.approx(1.0)
    readings = w.readings()
    sensors = {r["sensor"] for r in readings}
    assert {"encoders", "laser"} <= sensors
    assert all(0.0 <= r["t_s"] <= 1.0 + 1e-9 for r in readings)
    assert [r["t_s"] for r in readings] == sorted(r["t_s"] for r in readings)
    laser = [r for r in readings if r["sensor"] == "laser"][-1]
    assert laser["ranges_m"].dtype == np.float32 and laser["ranges_m"].size > 100
    # What on_laser gets beside the ranges, and a run's readings("laser") and sensors.json say.
    run = locsim.run(DEMO, tmp_path / "run", duration=0.2, seed=2)
    described = run.sensors()["laser"]
    np.testing.assert_array_equal(laser["angles_rad"], described["beam_angles_rad"])
    assert laser["range_min_m"] == described["min_range_m"] and laser["range_max_m"] == described["max_range_m"]
    mount = described["mount"]
    np.testing.assert_allclose(laser["mount"], [mount["x"], mount["y"], mount["theta"]], atol=1e-12)
    cameras = [r for r in readings if r["sensor"] in ("ptz_camera", "omni_camera") and len(r["detections"])]
    assert cameras and set(cameras[0]["detections"].dtype.names) == {"id", "range_m", "bearing_rad", "target",
                                                                       "truth_id"}
    assert len(cameras[0]["colors"]) == len(cameras[0]["detections"])
    assert w.readings() == []  # taken
    w.run_until(25.0)  # the demo's first kidnap is at 20 s
    assert "kidnap" in [e["kind"] for e in w.events()]


def test_a_robot_without_a_driver_takes_commands(tmp_path):
    world = tmp_path / "w.yaml"
    world.write_text(open(DEMO).read().split("\nscenario:")[0] + "\nscenario: {duration_s: 5}\n")
    w = locsim.World(world, seed=1, variation=False)
    start = w.truth()[0].copy()
    w.command(0, 0.3, 0.0)
    w.run_until(2.0)
    moved = w.truth()[0] - start
    assert 0.3 < np.hypot(moved[0], moved[1]) < 0.7
    with pytest.raises(KeyError):
        w.command("no_such_robot", 0.1, 0.0)
    with pytest.raises(IndexError):
        w.command(7, 0.1, 0.0)


def test_bad_input_names_the_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nphysics: {step_hz: -5}\n")
    with pytest.raises(ValueError, match="bad.yaml"):
        locsim.World(bad)
