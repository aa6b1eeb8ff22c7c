"""The `locsim` binary from Python: run a world, replay a log, run a sweep, write a report. Each
call waits for the binary and returns the folder it wrote, loaded (`Run` or `Sweep`).

The binary is $LOCSIM_BINARY if set, else the build next to this package (build/locsim in the
source tree, or bin/locsim of an install), else `locsim` on the PATH.
"""

import os
import shutil
import subprocess

# docs/run_folder.md "Exit codes": what each of the binary's exit codes means.
EXIT_CODES = {1: "failure not caused by the input", 2: "bad input", 3: "localizer plugin not found, "
              "not loadable or its create failed", 4: "video or frames cannot be rendered or written",
              5: "a localizer failed (the others' results are written)", 130: "interrupted"}


class LocsimError(RuntimeError):
    """The binary exited with an error: `code` is its exit code, `stderr` what it printed."""

    def __init__(self, command, code, stderr):
        self.command, self.code, self.stderr = command, code, stderr
        meaning = EXIT_CODES.get(code, "error")
        super().__init__(f"locsim exited with {code} ({meaning}): {' '.join(command)}\n{stderr.strip()}")


def binary():
    """The path of the locsim binary this package drives."""
    env = os.environ.get("LOCSIM_BINARY")
    if env:
        return env
    here = os.path.dirname(os.path.abspath(__file__))
    try:  # an install writes where its binary is (python/CMakeLists.txt)
        from ._installed import BINARY_FROM_PACKAGE
        candidates = [os.path.join(here, BINARY_FROM_PACKAGE)]
    except ImportError:  # the source tree: python/locsim, the build in build/
        candidates = [os.path.join(here, "..", "..", "build", "locsim")]
    for candidate in candidates:
        if os.access(candidate, os.X_OK) and os.path.isfile(candidate):
            return os.path.normpath(candidate)
    found = shutil.which("locsim")
    if found:
        return found
    raise FileNotFoundError("no locsim binary: build it (tools/build) or set LOCSIM_BINARY")


def _options(options):
    """Keyword arguments as command-line options: seed=3 -> --seed 3, overwrite=True ->
    --overwrite, localizer=[a, b] -> --localizer a --localizer b; None and False are left out."""
    out = []
    for key, value in options.items():
        flag = "--" + key.replace("_", "-")
        if value is None or value is False:
            continue
        if value is True:
            out.append(flag)
        elif isinstance(value, (list, tuple)):
            for v in value:
                out += [flag, str(v)]
        else:
            out += [flag, str(value)]
    return out


def call(*args, check=True, quiet=True):
    """Runs `locsim ARGS...`; returns the CompletedProcess. With `check`, an exit code other than 0
    (and 5, a localizer's failure, whose results are written) raises LocsimError."""
    command = [binary(), *map(str, args)]
    result = subprocess.run(command, capture_output=quiet, text=True)
    if check and result.returncode not in (0, 5):
        raise LocsimError(command, result.returncode, result.stderr or "")
    return result


def run(world, out, localizers=(), **options):
    """`locsim run WORLD --out OUT --localizer L ...` with any other option as a keyword (seed=2,
    duration=30, scenario=..., overwrite=True, isolation="none", video="run.mp4"); returns the Run.
    A localizer that fails does not raise: its status in the Run says why."""
    from .run_folder import Run

    call("run", world, "--out", out, "-q", *_options({"localizer": list(localizers), **options}))
    return Run(out)


def replay(log, out, localizers=(), **options):
    """`locsim replay LOG --out OUT --localizer L ...` (a log recorded with --log, or imported);
    returns the Run."""
    from .run_folder import Run

    call("replay", log, "--out", out, "-q", *_options({"localizer": list(localizers), **options}))
    return Run(out)


def sweep(experiment, out, jobs=None, **options):
    """`locsim sweep EXPERIMENT --out OUT --jobs N` (resume=True, shard="1/2", ...); returns the
    Sweep. Runs that fail are in its results, not raised."""
    from .sweep_folder import Sweep

    call("sweep", experiment, "--out", out, *_options({"jobs": jobs, **options}))
    return Sweep(out)


def report(folder):
    """`locsim report FOLDER`: writes FOLDER/report.md and FOLDER/report/*.png; returns the path of
    report.md."""
    call("report", folder)
    return os.path.join(folder, "report.md")
