#!/usr/bin/env bash
# Runs the MRCLAM Dataset 6 measurement scripts in the order their outputs need, at the lowest
# CPU priority. Each script's stdout goes to $S2R_OUT/NAME_out.txt; the pickle caches and
# s8_results.csv go to $S2R_OUT as well.
#
#   MRCLAM_DIR=/path/to/MRCLAM_Dataset6 [S2R_OUT=/path/to/out] [PYTHON=python3] ./run_all.sh
#
# MRCLAM_DIR: the extracted MRCLAM_Dataset6 folder (UTIAS MRCLAM benchmark,
#   http://asrl.utias.utoronto.ca/datasets/mrclam/).
# S2R_OUT: where the outputs go; default: the folder `out` beside this script.
# PYTHON: an interpreter with numpy, pandas and scipy; default: python3.
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)

if [ -z "${MRCLAM_DIR:-}" ]; then
  echo "MRCLAM_DIR is not set. Get MRCLAM Dataset 6 from the UTIAS MRCLAM benchmark," >&2
  echo "http://asrl.utias.utoronto.ca/datasets/mrclam/, extract it, and set MRCLAM_DIR to the" >&2
  echo "extracted MRCLAM_Dataset6 folder (the one that holds Barcodes.dat)." >&2
  exit 2
fi
export MRCLAM_DIR
S2R_OUT=${S2R_OUT:-$HERE/out}
mkdir -p "$S2R_OUT"
S2R_OUT=$(cd "$S2R_OUT" && pwd)
export S2R_OUT
PYTHON=${PYTHON:-python3}
if ! "$PYTHON" -c 'import numpy, pandas, scipy' 2>/dev/null; then
  echo "$PYTHON lacks numpy, pandas or scipy; set PYTHON to an interpreter that has them." >&2
  exit 2
fi

run() {  # run NAME SCRIPT [ARGS...]
  local name=$1 script=$2; shift 2
  echo "[$(date +%T)] $script -> $S2R_OUT/${name}_out.txt" >&2
  nice -n 19 "$PYTHON" "$HERE/$script" "$@" > "$S2R_OUT/${name}_out.txt"
}

run explore  explore.py
run s1       s1_detections.py         # writes det_inliers.pkl, det_all.pkl
run s1b      s1b_range_bearing.py     # reads det_inliers.pkl
run s1c      s1c_bias_after_depth.py
run s1d      s1d_robot5.py
run s2       s2_autocorr.py
run s3       s3_timestamp.py          # reads det_all.pkl
run s4       s4_offset.py
run s5       s5_odometry.py           # writes s5_grid.pkl, s5_lag.pkl
run s5b      s5b_scale.py             # reads s5_grid.pkl, s5_lag.pkl
run s5c      s5c_odo_shift.py         # reads s5_grid.pkl
run s6       s6_misses.py             # writes s6_visible.pkl
run s7       s7_optimism.py
run s8       s8_ekf.py                # reads s5_grid.pkl, s5_lag.pkl, s6_visible.pkl; writes s8_results.csv
run s8_table s8_table.py              # reads s8_results.csv
echo "[$(date +%T)] done: $S2R_OUT" >&2
