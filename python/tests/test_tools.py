"""The project's Python tools run on this package (each finds it through tools/locsim_path.py,
with no PYTHONPATH) and quote its statistics."""
import os
import subprocess
import sys

import numpy as np

import locsim


def tool(source_dir, name, *args):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run([sys.executable, os.path.join(source_dir, "tools", name), *map(str, args)],
                          capture_output=True, text=True, env=env, check=True).stdout


def test_paper_table_quotes_student_t(source_dir, small_sweep):
    out = tool(source_dir, "paper003_table.py", "lab", small_sweep.path)
    row = next(line for line in out.splitlines() if line.startswith("| ekf |"))
    x_rms = []
    for _, run in small_sweep.runs("ekf"):
        e = run.error_arrays("ekf")
        x_rms.append(float(np.sqrt(np.mean(e["dx_m"] ** 2))))
    mean, half = locsim.mean_ci(x_rms)
    assert row.split("|")[2].strip() == f"{mean:.3f} ± {half:.3f}"


def test_plot_and_odometry_error(source_dir, demo_run, tmp_path):
    png = tmp_path / "trajectory.png"
    tool(source_dir, "plot_run.py", demo_run.path, "--out", png)
    assert png.stat().st_size > 10_000
    out = tool(source_dir, "odometry_error.py", demo_run.path)
    assert out.startswith("all ") and "error sd: along" in out
