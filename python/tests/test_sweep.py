"""locsim.load_sweep against the sweep the binary wrote."""
import os
import shutil
import subprocess

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


def without_write_rights(command):
    """`command` run so that a read-only folder cannot be written: as root (who may write into any
    folder), without CAP_DAC_OVERRIDE."""
    if os.geteuid() == 0:
        return ["setpriv", "--bounding-set=-dac_override", "--inh-caps=-dac_override", "--", *command]
    return command


def test_report_into_a_read_only_folder_says_so_and_exits_with_1(small_sweep, tmp_path):
    """Issue 49: before, a Python traceback (exit 1 by accident); now the file and the reason, exit 1
    as documented, nothing half-written, an earlier report.md left whole."""
    folder = tmp_path / "sweep"
    shutil.copytree(small_sweep.path, folder)
    shutil.rmtree(folder / "report", ignore_errors=True)
    (folder / "report.md").write_text("an earlier report\n")
    before = sorted(os.listdir(folder))
    report = [locsim.binary(), "report", str(folder)]
    os.chmod(folder, 0o555)
    try:
        result = subprocess.run(without_write_rights(report), capture_output=True, text=True)
    finally:
        os.chmod(folder, 0o755)
    assert result.returncode == 1, result.stdout + result.stderr
    assert "Traceback" not in result.stderr
    assert f"report: cannot write {folder / 'report'}: Permission denied" in result.stderr
    assert sorted(os.listdir(folder)) == before
    # Its report/ folder read-only: the first plot cannot be written.
    (folder / "report").mkdir()
    os.chmod(folder / "report", 0o555)
    try:
        result = subprocess.run(without_write_rights(report), capture_output=True, text=True)
    finally:
        os.chmod(folder / "report", 0o755)
    assert result.returncode == 1, result.stdout + result.stderr
    assert "Traceback" not in result.stderr
    assert f"report: cannot write {folder / 'report'}{os.sep}" in result.stderr
    assert "Permission denied" in result.stderr
    assert (folder / "report.md").read_text() == "an earlier report\n"
    assert os.listdir(folder / "report") == []
    # Writable: written, exit 0.
    assert subprocess.run(report, capture_output=True).returncode == 0
    assert "## Summary" in (folder / "report.md").read_text()
