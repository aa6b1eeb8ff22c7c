"""Evaluates calls of the Python SDK (python/locsim/models.py, particles.py) that
tests/python_sdk_test.cpp lists in a JSON file: [{"fn": name, "args": [...], "kwargs": {...}}, ...].
Lists become float arrays, {"OdometryNoise": {...}} the dataclass; prints the results as JSON."""
import json
import sys

import numpy as np

import locsim


def decode(a):
    if isinstance(a, dict) and "OdometryNoise" in a:
        return locsim.OdometryNoise(**a["OdometryNoise"])
    return np.array(a, dtype=float) if isinstance(a, list) else a


def encode(r):
    if isinstance(r, (tuple, list)):
        return [encode(v) for v in r]
    return np.asarray(r, dtype=float).tolist()


cases = json.load(open(sys.argv[1]))
out = [encode(getattr(locsim, c["fn"])(*[decode(a) for a in c["args"]], **c.get("kwargs", {}))) for c in cases]
print(json.dumps(out))
