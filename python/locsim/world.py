"""The simulation stepped from Python: `locsim.World`, over the compiled module _locsim_world
(python/ext/world_module.cpp), which the build puts in build/python and an install beside this
package.

    >>> w = locsim.World("worlds/demo/demo.yaml", seed=3)
    >>> w.run_until(10.0)                  # physics steps taken
    >>> w.truth()                          # (robots, 3): x, y, theta of each robot
    >>> [r for r in w.readings() if r["sensor"] == "laser"][-1]["ranges_m"]
"""

import glob
import importlib
import os
import sys

from .cli import binary

_module = None


def _extension():
    """_locsim_world, found where the build or an install put it (or LOCSIM_PYTHON_EXTENSION_DIR)."""
    global _module
    if _module is not None:
        return _module
    here = os.path.dirname(os.path.abspath(__file__))
    folders = [os.environ.get("LOCSIM_PYTHON_EXTENSION_DIR"),
               os.path.dirname(here)]  # an install: share/locsim/python/_locsim_world*.so
    try:
        folders.append(os.path.join(os.path.dirname(binary()), "python"))  # the build: build/python
    except FileNotFoundError:
        pass
    for folder in folders:
        if folder and glob.glob(os.path.join(folder, "_locsim_world*.so")):
            if folder not in sys.path:
                sys.path.insert(0, folder)
            break
    try:
        _module = importlib.import_module("_locsim_world")
    except ImportError as e:
        raise ImportError(f"locsim.World needs the compiled module _locsim_world, built for Debian's python3 "
                          f"by tools/build into build/python ({e}); this is Python "
                          f"{sys.version_info.major}.{sys.version_info.minor} at {sys.executable}") from e
    return _module


def World(world, seed=1, scenario=None, duration=None, variation=True):  # noqa: N802  (a class to its users)
    """A world as `locsim run WORLD --seed SEED` loads it (its scenario, or `scenario`, a YAML file;
    `duration` [s] overrides the scenario's; `variation=False` as --no-variation), ready to step.
    The same seed gives the same run: step it to the end and its state_hash() is run.json's.

    Members: step(steps=1) and run_until(t_s) (physics steps taken; fewer at the scenario's end),
    truth() (robots, 3), readings() and events() since the last call (lists of dicts: t_s, robot,
    sensor, then the sensor's fields, detections as structured arrays with the truth_id the filters
    never see), command(robot, v_mps, omega_radps) for a robot the scenario does not drive (by name
    or index), time_s, dt_s, step_index, end_step, done, seed, robots, name, state_hash().
    Bad input raises ValueError naming the file, line and key."""
    return _extension().World(os.fspath(world), seed, None if scenario is None else os.fspath(scenario),
                              duration, variation)
