#!/usr/bin/env bash
# Calibrated on some robots, used on the others (README.md, "Calibrated on some robots, used on
# the others"): MRCLAM Dataset 6 calibrated on robots 1-3 and on robots 4-5; each calibration's
# localizer parameters replayed on the other robots' real logs (five landmark filters, three
# seeds), and robots 4 and 5 twinned from robots 1-3's calibration (three recording seeds).
# Also prints each robot's own calibration of the command response and the range model.
#
#   MRCLAM_DIR=/path/to/MRCLAM_Dataset6 [OUT=/tmp/s2r_cross] [LOCSIM=build/locsim] ./cross_robot.sh
#
# About 2 minutes on the 2-core VM. Needs pandas (for the table only).
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=mrclam_logs.sh
source "$HERE/mrclam_logs.sh" /tmp/s2r_cross
"$LOCSIM" calibrate ds6.locsimlog --robots robot1,robot2,robot3 --out cal_123 --overwrite
"$LOCSIM" calibrate ds6.locsimlog --robots robot4,robot5 --out cal_45 --overwrite
for n in 1 2 3 4 5; do
  echo "robot $n:"
  "$LOCSIM" calibrate ds6.locsimlog --robots robot$n --out cal_r$n --overwrite | grep -E "reported|range model"
done
localizers="localizers:
$landmark_filters
timeout_s: 600"
sweep() {  # NAME LOGS PARAMS [SEEDS]
  printf 'name: %s\nlogs: [%s]\n%sparams_file: %s\n%s\n' "$1" "$2" "${4:-}" "$3" "$localizers" > "$1.yaml"
  rm -rf "runs/$1"
  "$LOCSIM" sweep "$1.yaml" --jobs 2 --out "runs/$1" > /dev/null
}
seeds=$'seeds: {from: 1, to: 3}\n'
sweep r45_own "ds6_r4.locsimlog, ds6_r5.locsimlog" cal_45/calibration.yaml "$seeds"
sweep r45_from123 "ds6_r4.locsimlog, ds6_r5.locsimlog" cal_123/calibration.yaml "$seeds"
sweep r123_own "ds6_r1.locsimlog, ds6_r2.locsimlog, ds6_r3.locsimlog" cal_123/calibration.yaml "$seeds"
sweep r123_from45 "ds6_r1.locsimlog, ds6_r2.locsimlog, ds6_r3.locsimlog" cal_45/calibration.yaml "$seeds"
logs=""
mkdir -p twin
for n in 4 5; do
  "$LOCSIM" twin ds6_r$n.locsimlog --calibration cal_123/calibration.yaml --out twin/r$n.yaml --overwrite > /dev/null
  for s in 1 2 3; do
    "$LOCSIM" run twin/r$n.yaml --seed $s --log twin/r${n}_s$s.locsimlog --out twin/run_r${n}_s$s \
      --no-readings -q --overwrite
    logs="$logs${logs:+, }twin/r${n}_s$s.locsimlog"
  done
done
# No seeds: each twin run's localizers take its recording's seed.
sweep twin45_from123 "$logs" cal_123/calibration.yaml
"${PYTHON:-python3}" - <<'PY'
import pandas as pd
for name in ("r45_own", "r45_from123", "twin45_from123", "r123_own", "r123_from45"):
    d = pd.read_csv(f"runs/{name}/summary.csv")
    for _, r in d.iterrows():
        print(f"{name:15s} {r.config:14s} {r.position_rms_m_mean:.3f} ± {r.position_rms_m_ci95:.3f} m, "
              f"heading {r.heading_rms_deg_mean:.2f} deg, in 95 % ellipse {r.inside_95_ellipse_mean:.2f}")
PY
