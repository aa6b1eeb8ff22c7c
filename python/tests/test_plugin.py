"""Localizers written in Python: the declarations the host reads from a script's text, and a
numpy particle filter run through the binary from Python, beside a C++ filter."""
import os
import subprocess
import sys

import pytest

import locsim

DESCRIBE = os.path.join(os.path.dirname(locsim.__file__), "_describe.py")


def describe(path):
    return subprocess.run([sys.executable, "-I", "-S", DESCRIBE, str(path)], capture_output=True, text=True)


def script(tmp_path, body, name="f.py"):
    path = tmp_path / name
    path.write_text("import numpy as np\nimport locsim\n\n\nclass F(locsim.Localizer):\n" + body)
    return path


def test_declarations_are_read_without_running(tmp_path):
    path = script(tmp_path, '    """One line.\n\n    More."""\n'
                            '    params = [locsim.param("n", int, 5, 1, 10, "count [-]"),\n'
                            '              locsim.param("on", bool, False, doc="switch")]\n'
                            '    raise SystemExit("the class body never runs")\n'
                            '    def on_laser(self, t_s, scan): pass\n'
                            '    def estimate(self): pass\n', name="My-Filter.py")
    out = describe(path)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[:4] == ["name\tmy_filter", "description\tOne line.", "class\tF", f"readings\t{1 << 5}"]
    assert lines[4:] == ["param\tn\tint\t5\t1\t10\tcount [-]", "param\ton\tbool\t0\t\t\tswitch"]


def test_the_sdks_noise_lists_are_declared_as_the_cpp_filters_declare_them(tmp_path):
    """`+ locsim.detection_noise_params(...)` and `+ locsim.motion_noise_params()` in `params`: read
    without running, with the filter's own defaults; the same rows locsim.Localizer subclasses get."""
    path = script(tmp_path, '    params = ([locsim.param("n", int, 5, 1, 10, "count [-]")]\n'
                            '              + locsim.detection_noise_params(sigma_bearing_deg=5.0)\n'
                            '              + locsim.motion_noise_params())\n'
                            '    def estimate(self): pass\n')
    out = describe(path)
    assert out.returncode == 0, out.stderr
    params = {line.split("\t")[1]: line.split("\t")[2:] for line in out.stdout.splitlines() if line.startswith("param\t")}
    assert list(params)[0] == "n" and len(params) == 1 + 4 + 12
    assert params["sigma_bearing_deg"][:4] == ["double", "5.0", "1e-06", "180.0"]
    assert params["sigma_range_m"][:4] == ["double", "0.02", "1e-06", "100.0"]
    assert params["motion_model"][:2] == ["string", "odometry"] and params["variance_form"][:2] == ["bool", "0"]
    declared = {p.name: p for p in locsim.detection_noise_params(sigma_bearing_deg=5.0) + locsim.motion_noise_params()}
    for name, fields in params.items():
        if name != "n":
            assert fields[0] == {"float": "double", "bool": "bool", "str": "string"}[declared[name].type.__name__]

    bad = describe(script(tmp_path, '    params = locsim.detection_noise_params(sigma_bearing=5.0)\n'
                                    '    def estimate(self): pass\n'))
    assert bad.returncode == 1
    assert "6: detection_noise_params: no parameter 'sigma_bearing' here" in bad.stderr


def test_the_sdks_noise_lists_are_the_cpp_filters_declarations():
    """noise_params.py states the C++ filters' declarations once more, for Python: `locsim plugins`
    (mcl's, ekf_landmarks' for the LostWatch) must list the same types, defaults and ranges."""
    from locsim import noise_params

    listing = subprocess.run([locsim.binary(), "plugins"], capture_output=True, text=True).stdout

    def declared_by(plugin):
        block = listing.split(f"\n{plugin}  ", 1)[1].split("\n\n", 1)[0]
        declared = {}
        for line in block.splitlines()[2:]:
            fields = line.split()
            declared[fields[0]] = (fields[1], fields[3].strip("'"),
                                   " ".join(fields[5:7]) if fields[4:5] == ["in"] else "")
        return declared
    kinds = {float: "double", int: "int", bool: "bool", str: "string"}
    for plugin, rows in (("mcl", noise_params.DETECTION_NOISE + noise_params.MOTION_NOISE),
                         ("ekf_landmarks", noise_params.LOST)):
        declared = declared_by(plugin)
        for name, kind, default, low, high, _ in rows:
            shown = "true" if default is True else "false" if default is False else default \
                if isinstance(default, str) else f"{default:g}"
            bounds = f"[{low:g}, {high:g}]" if low is not None else ""
            assert declared[name] == (kinds[kind], shown, bounds), name


@pytest.mark.parametrize("body, line, message", [
    ('    params = [locsim.param("n", int, 50, 1, 10)]\n    def estimate(self): pass\n', 6, "outside [1, 10]"),
    ('    params = [locsim.param("N", int, 5)]\n    def estimate(self): pass\n', 6, "must be [a-z0-9_]+"),
    ('    name = "a" + "b"\n    def estimate(self): pass\n', 6, "must be a literal"),
    ('    params = [locsim.param("x", float, 1.0), locsim.param("x", int, 1)]\n    def estimate(self): pass\n', 6,
     "declared twice"),
    ('    def on_odometry(self, t_s, o): pass\n', 5, "defines no estimate"),
])
def test_bad_declarations_name_the_line(tmp_path, body, line, message):
    out = describe(script(tmp_path, body))
    assert out.returncode == 1
    assert out.stderr.startswith(f"{tmp_path / 'f.py'}:{line}: ") and message in out.stderr


def test_numpy_particle_filter_through_the_binary(tmp_path):
    demo = os.path.join(os.environ.get("LOCSIM_SOURCE_DIR", ""), "worlds", "demo", "demo.yaml")
    if not os.path.exists(demo):
        demo = os.path.join(os.path.dirname(__file__), "..", "..", "worlds", "demo", "demo.yaml")
    run = locsim.run(demo, tmp_path / "pf", localizers=["ekf_landmarks", "python:landmark_pf:particles=300@pf"],
                     duration=8, seed=5)
    summary = run.summary().set_index("label")
    assert (summary.status == "ok").all(), summary.failure
    assert summary.loc["pf", "plugin"] == "landmark_pf"
    params = run.localizer_metrics("pf")["params"]
    assert params["particles"] == 300 and params["sigma_range_m"] == 0.02 and params["roughening_deg"] == 0.5
    errors = run.errors("pf")
    assert len(errors) == run.localizer_metrics("pf")["samples"]
    assert summary.loc["pf", "position_rms_m"] < 0.5
