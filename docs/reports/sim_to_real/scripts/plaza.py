#!/usr/bin/env python3
"""Converts a CMU Plaza range-only dataset (Plaza1.mat, Plaza2.mat: a lawnmower ranging to four
UWB beacons, with RTK-GPS truth) into locsim's generic format (docs/real_data.md), for
`locsim import generic`.

    plaza.py Plaza1.mat OUT_DIR

Where to get the files: github.com/gtrll/gpslam, matlab/data/Plaza1.mat and Plaza2.mat (the
datasets of Djugash and Singh's range-only SLAM work at CMU). Each holds, in MATLAB 5 format:
  GT  [t x y heading]        truth
  DR  [t distance turn]      odometry increments since the previous row
  TD  [t robot beacon range] UWB ranges
  TL  [beacon x y]           the beacons' surveyed positions
  init_heading_offset        added to GT's heading (Plaza2's truth faces backwards without it)
Written: beacons.csv, ranges.csv (sorted by time: Plaza1's are not, twice), odometry.csv (the
increments dead-reckoned in the odometry's own frame, from (0, 0, 0)), groundtruth.tum and
robot.yaml (one receiver at the robot's centre; the lawnmower's wheel base is not published: 0.5 m
is assumed, and only the motion noise's k, which calibrate fits, depends on it).

The MATLAB reader below handles what these files hold (numeric matrices, zlib-compressed
elements); it is not a general one.
"""
import math
import struct
import sys
import zlib
from pathlib import Path

import numpy as np

_NUMERIC = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 9: "f8", 12: "i8",
            13: "u8"}
_COMPRESSED, _MATRIX = 15, 14


def _elements(buf):
    """(type, bytes) of each data element in buf (MAT-file level 5 tags, small ones included)."""
    offset = 0
    while offset + 8 <= len(buf):
        kind, size = struct.unpack_from("<II", buf, offset)
        if kind >> 16:  # small element: size and type in one word, data in the next four bytes
            yield kind & 0xFFFF, buf[offset + 4:offset + 4 + (kind >> 16)]
            offset += 8
            continue
        yield kind, buf[offset + 8:offset + 8 + size]
        # Elements are padded to 8 bytes, compressed ones are not.
        offset += 8 + (size if kind == _COMPRESSED else (size + 7) // 8 * 8)


def _matrix(data):
    parts = list(_elements(data))
    (_, flags), (_, dims), (_, name) = parts[0], parts[1], parts[2]
    if flags[0] not in range(6, 16):
        return name.decode(), None  # cells, structs, text: not in these files' variables we use
    shape = tuple(np.frombuffer(dims, "<i4"))
    kind, values = parts[3]
    return name.decode(), np.frombuffer(values, _NUMERIC[kind]).astype(float).reshape(
        shape[::-1]).T


def load_mat(path):
    """The numeric variables of a MAT-file level 5, by name."""
    buf = Path(path).read_bytes()
    if not buf.startswith(b"MATLAB 5.0 MAT-file"):
        raise SystemExit(f"{path}: not a MATLAB 5 MAT-file")
    out = {}
    for kind, data in _elements(buf[128:]):
        if kind == _COMPRESSED:
            kind, data = next(_elements(zlib.decompress(data)))
        if kind == _MATRIX:
            name, value = _matrix(data)
            if value is not None:
                out[name] = value
    return out


def convert(mat_path, out):
    d = load_mat(mat_path)
    missing = {"GT", "DR", "TD", "TL"} - d.keys()
    if missing:
        raise SystemExit(f"{mat_path}: no {', '.join(sorted(missing))} in it")
    gt, dr, td, tl = d["GT"], d["DR"], d["TD"], d["TL"]
    offset = float(d.get("init_heading_offset", np.zeros((1, 1)))[0, 0])
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "beacons.csv", "w") as f:
        f.write("id,x,y\n")
        for beacon, x, y in tl:
            f.write(f"{int(beacon)},{x:.6f},{y:.6f}\n")
    with open(out / "ranges.csv", "w") as f:
        f.write("t,beacon,range\n")
        for t, _, beacon, r in td[np.argsort(td[:, 0], kind="stable")]:
            f.write(f"{t:.6f},{int(beacon)},{r:.6f}\n")
    with open(out / "odometry.csv", "w") as f:
        # The increments along the mid-heading of each step, from the first truth's time.
        f.write("t,x,y,theta\n")
        x = y = theta = 0.0
        f.write(f"{gt[0, 0]:.6f},0,0,0\n")
        for t, distance, turn in dr:
            x += distance * math.cos(theta + 0.5 * turn)
            y += distance * math.sin(theta + 0.5 * turn)
            theta += turn
            f.write(f"{t:.6f},{x:.6f},{y:.6f},{math.remainder(theta, 2 * math.pi):.8f}\n")
    with open(out / "groundtruth.tum", "w") as f:
        f.write("# t x y z qx qy qz qw\n")
        for t, x, y, heading in gt:
            half = 0.5 * math.remainder(heading + offset, 2 * math.pi)
            f.write(f"{t:.6f} {x:.6f} {y:.6f} 0 0 0 {math.sin(half):.9f} {math.cos(half):.9f}\n")
    with open(out / "robot.yaml", "w") as f:
        f.write("# CMU Plaza lawnmower: one UWB receiver at the centre; wheel base assumed.\n")
        f.write("radius_m: 0.5\nwheel_base_m: 0.5\nwheel_radius_m: 0.1\n")
        f.write("ultrasonic: {receivers: [{position: [0, 0], height_m: 0}]}\n")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    convert(sys.argv[1], sys.argv[2])
