"""locsim.load_sweep against the sweep the binary wrote; `locsim report` and `locsim compare`."""
import json
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
    assert result.stderr == f"locsim: failure: report: cannot write {folder / 'report'}: Permission denied\n"
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
    assert result.stderr.startswith(f"locsim: failure: report: cannot write {folder / 'report'}{os.sep}")
    assert "Permission denied" in result.stderr
    assert (folder / "report.md").read_text() == "an earlier report\n"
    assert os.listdir(folder / "report") == []
    # Writable: written, exit 0.
    assert subprocess.run(report, capture_output=True).returncode == 0
    assert "## Summary" in (folder / "report.md").read_text()


# `locsim report` and `locsim compare`: their messages follow the C++ side's (issue 49's audit):
# `locsim: error: ...` and exit 2 for bad input, naming the file (and line and column);
# `locsim: failure: ...` and exit 1 for the system's fault; untrusted text escaped; never a
# traceback.


@pytest.fixture(scope="module")
def small_run(tmp_path_factory, source_dir):
    """The demo world for 2 s with odometry."""
    out = tmp_path_factory.mktemp("runs") / "small"
    return locsim.run(os.path.join(source_dir, "worlds", "demo", "demo.yaml"), out,
                      localizers=["odometry"], duration=2, seed=1)


def locsim_cli(*args, cwd=None):
    return subprocess.run([locsim.binary(), *map(str, args)], capture_output=True, text=True,
                          errors="surrogateescape", cwd=cwd)


def expect_error(result, message, code=2, kind="error"):
    """`result` exited with `code` and printed one line, `locsim: KIND: ...` holding `message`,
    without a traceback or a control character."""
    assert result.returncode == code, result.stdout + result.stderr
    assert result.stderr.startswith(f"locsim: {kind}: "), result.stderr
    assert message in result.stderr, result.stderr
    assert result.stderr.count("\n") == 1 and result.stderr.endswith("\n"), result.stderr
    assert "Traceback" not in result.stderr
    assert not any(ord(c) < 0x20 or ord(c) == 0x7F for c in result.stderr[:-1]), repr(result.stderr)


def copy_folder(source, target):
    shutil.copytree(source, target)
    shutil.rmtree(os.path.join(target, "report"), ignore_errors=True)
    if os.path.exists(os.path.join(target, "report.md")):
        os.remove(os.path.join(target, "report.md"))
    return target


def json_position(text):
    """'LINE:COLUMN' of where `text` stops being JSON."""
    with pytest.raises(json.JSONDecodeError) as error:
        json.loads(text)
    return f"{error.value.lineno}:{error.value.colno}"


def test_report_names_the_file_line_and_column_it_cannot_read(small_run, small_sweep, tmp_path):
    """Before: `report: cannot read Rbad1: Expecting ',' delimiter: line 19 column 37 (char 500)`,
    Python's text without the file; now the file, line and column, exit 2, nothing written."""
    run = copy_folder(small_run.path, tmp_path / "Rbad1")
    text = (run / "run.json").read_text()[:500]
    (run / "run.json").write_text(text)
    result = locsim_cli("report", run)
    expect_error(result, f"locsim: error: report: {run / 'run.json'}:{json_position(text)}: not valid JSON (")
    assert not (run / "report.md").exists()

    run = copy_folder(small_run.path, tmp_path / "Rbad2")
    (run / "metrics.json").write_bytes(b"\x1b[31m\xff\xfe{{{")
    expect_error(locsim_cli("report", run),
                 f"locsim: error: report: {run / 'metrics.json'}:1:6: not UTF-8 (byte 0xff)")
    (run / "metrics.json").write_text('{"localizers": [{"label": "odometry"}]}')
    expect_error(locsim_cli("report", run), f"locsim: error: report: {run / 'metrics.json'}: no key '")

    run = copy_folder(small_run.path, tmp_path / "Rbad3")
    with open(run / "groundtruth.tum", "a") as f:
        f.write("nan nan nan\n")
    lines = (run / "groundtruth.tum").read_text().count("\n")
    expect_error(locsim_cli("report", run),
                 f"locsim: error: report: {run / 'groundtruth.tum'}:{lines}: a TUM line has 8 numbers")

    sweep = copy_folder(small_sweep.path, tmp_path / "Sbad3")
    (sweep / "sweep.json").write_bytes(b'\x1b[2J{"a":1}\n')
    expect_error(locsim_cli("report", sweep),
                 f"locsim: error: report: {sweep / 'sweep.json'}:1:1: not valid JSON (Expecting value)")
    # compare names it the same way.
    expect_error(locsim_cli("compare", sweep, small_sweep.path, "--out", tmp_path / "out"),
                 f"locsim: error: compare: {sweep / 'sweep.json'}:1:1: not valid JSON (Expecting value)")

    sweep = copy_folder(small_sweep.path, tmp_path / "Sbad5")
    rows = (sweep / "results.csv").read_text().split("\n")
    header = rows[0].split(",")
    fields = rows[2].split(",")
    fields[header.index("position_rms_m")] = "\x1b[31mbad"
    rows[2] = ",".join(fields)
    (sweep / "results.csv").write_text("\n".join(rows))
    expect_error(locsim_cli("report", sweep),
                 f"locsim: error: report: {sweep / 'results.csv'}:3: position_rms_m '\\x1b[31mbad' is "
                 "not a number")
    assert not (sweep / "report.md").exists()


def test_compare_refuses_labels_with_control_characters(small_sweep, tmp_path):
    """Before: exit 0, ESC on stderr through matplotlib's "Glyph 27 missing" warnings and 11 times
    in report.md. Labels name tables and plots: one with a control character is refused, escaped
    in the message."""
    out = tmp_path / "out"
    result = locsim_cli("compare", small_sweep.path, small_sweep.path, "--out", out,
                        "--labels", "\x1b[31ma\nx,b")
    expect_error(result, "locsim: error: compare: --labels: ")
    assert "'\\x1b[31ma\\x0ax,b'" in result.stderr
    assert not out.exists()
    # Names the font lacks are drawn, without matplotlib's warnings on stderr.
    result = locsim_cli("compare", small_sweep.path, small_sweep.path, "--out", out,
                        "--labels", "実機,twin")
    assert result.returncode == 0 and result.stderr == "", result.stderr
    assert "# Comparison: 実機 and twin" in (out / "report.md").read_text(encoding="utf-8")
    # Without --labels the folders' names are the labels: escaped.
    strange = copy_folder(small_sweep.path, tmp_path / "a\x1b[2Jb")
    out = tmp_path / "out2"
    result = locsim_cli("compare", strange, small_sweep.path, "--out", out)
    assert result.returncode == 0 and result.stderr == "", result.stderr
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "\x1b" not in md and "a\\x1b[2Jb" in md


def test_report_and_compare_messages_are_locsims(small_run, small_sweep, tmp_path):
    """Before: `report: ...` and `compare: ...`; now `locsim: error: ...` (exit 2) for bad input and
    `locsim: failure: ...` (exit 1) for the system's fault, as the C++ side's."""
    expect_error(locsim_cli("report", tmp_path / "nonexist"),
                 f"locsim: error: report: {tmp_path / 'nonexist'}: no such folder")
    (tmp_path / "empty").mkdir()
    expect_error(locsim_cli("report", tmp_path / "empty"),
                 f"locsim: error: report: {tmp_path / 'empty'} is neither a sweep, a run nor a "
                 "calibration folder")
    expect_error(locsim_cli("compare", small_sweep.path, tmp_path / "nonexist", "--out", tmp_path / "o"),
                 f"locsim: error: compare: {tmp_path / 'nonexist'}: no such folder")
    expect_error(locsim_cli("compare", small_sweep.path, small_sweep.path, "--out", tmp_path / "o",
                            "--labels", "a"),
                 "locsim: error: compare: --labels: expected NAME_A,NAME_B, got 'a'")
    # A full disk: the plot's temporary file is /dev/full.
    run = copy_folder(small_run.path, tmp_path / "run")
    (run / "report").mkdir()
    os.symlink("/dev/full", run / "report" / "error_vs_time.png.tmp")
    expect_error(locsim_cli("report", run),
                 f"locsim: failure: report: cannot write {run / 'report' / 'error_vs_time.png'}: No "
                 "space left on device", code=1, kind="failure")
    assert not (run / "report.md").exists() and os.listdir(run / "report") == []  # no .tmp left
    os.symlink("/dev/full", run / "report.md.tmp")
    expect_error(locsim_cli("report", run),
                 f"locsim: failure: report: cannot write {run / 'report.md'}: No space left on "
                 "device", code=1, kind="failure")
    out = tmp_path / "compared"
    (out / "report").mkdir(parents=True)
    os.symlink("/dev/full", out / "report" / "compare.png.tmp")
    expect_error(locsim_cli("compare", small_sweep.path, small_sweep.path, "--out", out),
                 f"locsim: failure: compare: cannot write {out / 'report' / 'compare.png'}: No space "
                 "left on device", code=1, kind="failure")
    assert not (out / "report.md").exists()


def test_report_on_a_run_that_did_not_finish(small_run, tmp_path):
    """run.json's status: "running" (a run still running, or killed) or "failed" (with "error"):
    exit 2 saying so, the error escaped and cut; "interrupted" (Ctrl-C): reported as far as it
    went."""
    run = copy_folder(small_run.path, tmp_path / "running")
    (run / "run.json").write_text(json.dumps({"status": "running", "seed": 1}))
    expect_error(locsim_cli("report", run),
                 f"locsim: error: report: {run / 'run.json'}: the run did not finish: status 'running'")
    assert not (run / "report.md").exists()

    run = copy_folder(small_run.path, tmp_path / "failed")
    info = json.loads((run / "run.json").read_text())
    info.update(status="failed", error="plugin 'x' crashed\x1b[31m at t = 1.5 s:\nsignal 11" + "!" * 500)
    (run / "run.json").write_text(json.dumps(info))
    result = locsim_cli("report", run)
    expect_error(result, f"locsim: error: report: {run / 'run.json'}: the run did not finish: status "
                 "'failed': 'plugin 'x' crashed\\x1b[31m at t = 1.5 s:\\x0asignal 11!!!")
    assert "bytes more)" in result.stderr and len(result.stderr) < 400

    run = copy_folder(small_run.path, tmp_path / "interrupted")
    info = json.loads((run / "run.json").read_text())
    info["status"] = "interrupted"
    (run / "run.json").write_text(json.dumps(info))
    result = locsim_cli("report", run)
    assert result.returncode == 0 and result.stderr == "", result.stderr
    assert "Interrupted (Ctrl-C)" in (run / "report.md").read_text()
    assert locsim.load_run(run).status == "interrupted"


def test_segments_are_a_tidy_table_of_each_runs_segments(tmp_path, source_dir):
    """Sweep.segments(): one row per run and segment between kidnaps, the scorer's figures as
    columns (segments.csv); the same rows rebuilt from results.jsonl for a sweep without the file;
    summary.csv's kidnap counts are those of the segments the scorer judged recoverable."""
    experiment = tmp_path / "kidnaps.yaml"
    experiment.write_text(f"""name: kidnaps
world: {os.path.join(source_dir, "worlds", "demo", "demo.yaml")}
duration_s: 44
seeds: {{from: 1, to: 2}}
localizers:
  - plugin: odometry
  - plugin: ekf_landmarks
    label: ekf
""")
    s = locsim.sweep(experiment, tmp_path / "out", jobs=2)
    segments = s.segments()
    records = sorted(s.records().values(), key=lambda r: r["index"])
    assert len(segments) == sum(len(r["metrics"]["segments"]) for r in records) == 4 * 3
    assert list(segments.segment) == [0, 1, 2] * 4  # two kidnaps, at 20 s and 40 s
    assert (segments[segments.segment == 0].from_s == 0).all()
    assert segments[segments.segment == 0].recoverable.isna().all()
    assert set(segments[segments.segment > 0].recoverable) <= {True, False}
    for row in segments.to_dict("records"):
        record = next(r for r in records if r["id"] == row["id"])
        segment = record["metrics"]["segments"][row["segment"]]
        assert row["position_rms_m"] == pytest.approx(segment["position_error_m"]["rms"], abs=1e-6)
        assert (row["recovery_s"] != row["recovery_s"]) == (segment["recovery_s"] is None)  # NaN: never
    assert len(s.segments("ekf")) == 6 and set(s.segments("ekf").config) == {"ekf"}
    first = segments[segments.segment == 0].set_index("id")  # results.csv's first_segment_ columns
    for row in s.results.to_dict("records"):
        assert row["first_segment_position_rms_m"] == pytest.approx(first.loc[row["id"], "position_rms_m"], abs=1e-6)
        assert (row["first_segment_nees_median"] == pytest.approx(first.loc[row["id"], "nees_median"], abs=1e-4)
                or row["first_segment_nees_median"] != row["first_segment_nees_median"])  # NaN: no covariance

    os.remove(os.path.join(s.path, "segments.csv"))  # a sweep of an older locsim
    rebuilt = locsim.load_sweep(s.path).segments()
    assert list(rebuilt.columns) == list(segments.columns)
    assert list(rebuilt.id) == list(segments.id) and list(rebuilt.segment) == list(segments.segment)
    assert rebuilt.position_rms_m.to_numpy() == pytest.approx(segments.position_rms_m.to_numpy(), abs=1e-6)

    for config in s.configs:
        rows = segments[(segments.config == config) & (segments.segment > 0)]
        criterion = records[0]["metrics"]["convergence"]  # a carry within it tests nothing
        moved = rows[(rows.carried_m > criterion["position_m"]) | (rows.turned_deg > criterion["heading_deg"])]
        recoverable = moved[moved.recoverable == True]  # noqa: E712  (a column of objects)
        summary = s.summary[s.summary.config == config].iloc[0]
        assert summary.kidnaps_recoverable == len(recoverable)
        assert summary.kidnaps_recovered == recoverable.recovery_s.notna().sum()
