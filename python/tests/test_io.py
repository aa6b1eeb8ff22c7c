"""locsim.io: the one reader of each file format."""
import math

import numpy as np
import pytest

import locsim
from locsim import io


def test_read_tum(tmp_path):
    path = tmp_path / "x.tum"
    theta = 3.0
    path.write_text("# timestamp tx ty tz qx qy qz qw\n"
                    f"0.0000 1.5 -2.25 0 0 0 {math.sin(theta / 2):.9f} {math.cos(theta / 2):.9f}\n"
                    f"0.0200 1.6 -2.25 0 0 0 {math.sin(-theta / 2):.9f} {math.cos(-theta / 2):.9f}\n")
    poses = locsim.read_tum(path)
    assert poses.shape == (2, 4)
    assert poses[0, :3].tolist() == [0.0, 1.5, -2.25]
    assert poses[0, 3] == pytest.approx(theta, abs=1e-8) and poses[1, 3] == pytest.approx(-theta, abs=1e-8)
    (tmp_path / "empty.tum").write_text("# no rows: a localizer that failed at once\n")
    assert locsim.read_tum(tmp_path / "empty.tum").shape == (0, 4)
    (tmp_path / "bad.tum").write_text("1 2 3\n")
    with pytest.raises(ValueError, match="bad.tum: a TUM line has 8 numbers"):
        locsim.read_tum(tmp_path / "bad.tum")


def test_join_on_time_pairs_equal_instants():
    truth = np.array([[0.0, 0, 0, 0], [0.02, 1, 0, 0], [0.04, 2, 0, 0], [2.5, 3, 0, 0]])
    estimate = np.array([[0.04, 2.5, 0, 0], [2.5000000001, 3.5, 0, 0]])  # float noise below 0.1 ms
    i, j = io.join_on_time(truth, estimate)
    assert i.tolist() == [2, 3] and j.tolist() == [0, 1]


def test_wrap_angle_and_events(tmp_path):
    assert np.allclose(locsim.wrap_angle([0.0, 3 * math.pi / 2, -3 * math.pi / 2]), [0.0, -math.pi / 2, math.pi / 2])
    # (-pi, pi] as the C++ SDK's wrap (IEEE remainder, then -pi moved to pi), seam included.
    angles = [math.pi, -math.pi, 3 * math.pi, -3 * math.pi, 7.0, -7.0, 1e-300, 100.0]
    for a in angles:
        cpp = math.remainder(a, 2 * math.pi)
        cpp = cpp + 2 * math.pi if cpp <= -math.pi else cpp
        assert locsim.wrap_angle(a) == pytest.approx(cpp, abs=1e-12), a
        assert -math.pi < locsim.wrap_angle(a) <= math.pi
    assert locsim.wrap_angle(math.pi) == math.pi and locsim.wrap_angle(-math.pi) == math.pi
    assert np.all(locsim.wrap_angle(np.array(angles)) > -math.pi)
    assert isinstance(locsim.wrap_angle(0.5), float)
    (tmp_path / "events.csv").write_text(
        "t_s,kind,robot,details\n"
        '20.0000,kidnap,robot,"from=(8.7101,2.1391,1.5508) carry_s=2.000 to=(1.2000,5.0000,-1.5708)"\n')
    (event,) = locsim.read_events(tmp_path / "events.csv")
    assert event["t_s"] == 20.0 and event["kind"] == "kidnap"
    assert event["details"]["to"] == (1.2, 5.0, -1.5708) and event["details"]["carry_s"] == "2.000"
    assert locsim.read_events(tmp_path / "none.csv") == []


def test_read_jsonl_drops_only_a_last_line_cut_short(tmp_path):
    """Issue 49: a sweep killed while writing leaves its last line cut short, without its line
    break; any other line that is not a JSON object is corruption, named by its file and line
    (before: skipped, and the results it held lost silently)."""
    path = tmp_path / "results.jsonl"
    path.write_text('{"index": 0}\n{"index": 1}\n{"ind')
    assert io.read_jsonl(path) == [{"index": 0}, {"index": 1}]
    path.write_text('{"index": 0}\n{"ind\n{"index": 2}\n')
    with pytest.raises(ValueError, match=r"results.jsonl:2: not a JSON object"):
        io.read_jsonl(path)
    path.write_text('{"index": 0}\n' + '{"index": 1, "reason": "' + "x" * 100000 + '\n')
    with pytest.raises(ValueError) as error:
        io.read_jsonl(path)
    assert "results.jsonl:2:" in str(error.value) and len(str(error.value)) < 600


def test_bad_files_are_named_with_their_line(tmp_path):
    """What `locsim report` prints about a file it cannot read (issue 49's audit): the file, line
    (and column), not Python's text alone; FormatError is a ValueError, as before."""
    path = tmp_path / "run.json"
    path.write_text('{\n  "seed": 1,\n  "status": "compl')
    with pytest.raises(io.FormatError, match=r"run.json:3:13: not valid JSON \(Unterminated string"):
        io.read_json(path)
    path.write_bytes(b'{"a":\n "\x1b[31m\xff"}')
    with pytest.raises(ValueError, match=r"run.json:2:8: not UTF-8 \(byte 0xff\)"):
        io.read_json(path)
    path = tmp_path / "groundtruth.tum"
    path.write_text("# t x y z qx qy qz qw\n0 1 2 0 0 0 0 1\nnan nan nan\n")
    with pytest.raises(io.FormatError, match=r"groundtruth.tum:3: a TUM line has 8 numbers .*not 3"):
        io.read_tum(path)
    path.write_text("0 1 2 0 0 0 0 1\n0.1 1 2 0 0 0 zero 1\n")
    with pytest.raises(io.FormatError, match=r"groundtruth.tum:2: 'zero' is not a number"):
        io.read_tum(path)
    path = tmp_path / "events.csv"
    path.write_text("t_s,kind,robot,details\n20.0,kidnap,robot,\nsoon,kidnap,robot,\n")
    with pytest.raises(io.FormatError, match=r"events.csv:3: t_s 'soon' is not a number"):
        io.read_events(path)
