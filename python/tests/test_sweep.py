"""locsim.load_sweep against the sweep the binary wrote."""
import pytest

import locsim


def test_results_runs_and_errors(small_sweep):
    s = locsim.load_sweep(small_sweep.path)
    assert s.configs == ["odometry", "ekf"]
    assert len(s.results) == 8 and (s.results.status == "ok").all()
    assert set(s.records()) == set(s.results.id)
    pairs = list(s.runs("ekf"))
    assert [row["seed"] for row, _ in pairs] == [1, 2, 3, 4]
    for row, run in pairs:
        assert run.seed == row["seed"] and run.labels() == ["ekf"]
        e = run.errors("ekf")
        assert locsim.run_folder.rms(e.position_error_m) == pytest.approx(row["position_rms_m"], abs=2e-6)
    errors = s.errors()
    assert set(errors.config) == {"odometry", "ekf"} and set(errors.seed) == {1, 2, 3, 4}
    assert s.run("ekf", 2).path == pairs[1][1].path
    with pytest.raises(KeyError):
        s.run("ekf", 9)


def test_seeds_vary_the_world(small_sweep):
    """Seeds draw the world (issue 19): two seeds' ground truths differ, as a loaded sweep shows."""
    a, b = small_sweep.run("odometry", 1).truth(), small_sweep.run("odometry", 2).truth()
    assert a.shape == b.shape and (a[:, 1:] != b[:, 1:]).any()


def test_not_a_sweep_folder(tmp_path):
    with pytest.raises(FileNotFoundError, match="not a sweep folder"):
        locsim.load_sweep(tmp_path)


def test_report_uses_the_package(small_sweep):
    """`locsim report` runs tools/report.py, which finds this package by itself (no PYTHONPATH):
    its summary quotes the same CIs as summary.md."""
    path = locsim.report(small_sweep.path)
    text = open(path, encoding="utf-8").read()
    assert "## Summary" in text and "ekf" in text
