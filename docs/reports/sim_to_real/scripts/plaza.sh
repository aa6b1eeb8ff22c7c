#!/usr/bin/env bash
# Range-only beacons on real data (README.md, "Range-only beacons: the CMU Plaza datasets"): the
# lawnmower of CMU's Plaza 1 and Plaza 2 datasets ranging to four UWB beacons, with RTK-GPS
# truth, converted to the generic format (plaza.py), imported, calibrated on both recordings
# together (each alone too, with the transfer check), replayed with the beacon filters, and
# twinned (three seeds each).
#
#   PLAZA_DIR=/folder/with/Plaza1.mat+Plaza2.mat [OUT=/tmp/plaza] [LOCSIM=build/locsim] ./plaza.sh
#
# The files: github.com/gtrll/gpslam, matlab/data/Plaza1.mat and Plaza2.mat. About 5 minutes on
# the 2-core VM.
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
if [ -z "${PLAZA_DIR:-}" ]; then
  echo "PLAZA_DIR is not set: the folder holding Plaza1.mat and Plaza2.mat" >&2
  echo "(github.com/gtrll/gpslam, matlab/data)." >&2
  exit 2
fi
LOCSIM=$(realpath "${LOCSIM:-$HERE/../../../../build/locsim}")
OUT=${OUT:-/tmp/plaza}
mkdir -p "$OUT"
cd "$OUT"
filters=(--localizer odometry --localizer ultrasonic_ekf --localizer beacon_mcl)
for n in 1 2; do
  [ -d plaza$n ] || /usr/bin/python3 "$HERE/plaza.py" "$PLAZA_DIR/Plaza$n.mat" plaza$n
  [ -f plaza$n.locsimlog ] || "$LOCSIM" import generic plaza$n --out plaza$n.locsimlog -q
done
echo "== calibrated on both, each alone, and checked one on the other"
"$LOCSIM" calibrate plaza1.locsimlog plaza2.locsimlog --out cal --check ultrasonic_ekf,beacon_mcl \
  --check-seeds 3 --jobs 2 --overwrite
for n in 1 2; do
  "$LOCSIM" twin plaza$n.locsimlog --out twin/plaza$n.yaml --calibration cal/calibration.yaml \
    --overwrite -q
  for seed in 1 2 3; do
    "$LOCSIM" replay plaza$n.locsimlog --out real/plaza${n}_s$seed --seed $seed --overwrite -q \
      --params cal/calibration.yaml "${filters[@]}" 2>/dev/null
    "$LOCSIM" run twin/plaza$n.yaml --seed $seed --no-readings -q --overwrite \
      --out twin/runs/plaza${n}_s$seed --log twin/plaza${n}_s$seed.locsimlog
    "$LOCSIM" replay twin/plaza${n}_s$seed.locsimlog --out twin/replay/plaza${n}_s$seed --seed $seed \
      --overwrite -q --params cal/calibration.yaml "${filters[@]}" 2>/dev/null
  done
done
echo "== real against twin (position RMS, truth in the 95 % ellipse; mean of three seeds)"
/usr/bin/python3 - <<'EOF'
import json
rows = {}
for n in (1, 2):
    for kind, folder in (("real", "real"), ("twin", "twin/replay")):
        for seed in (1, 2, 3):
            m = json.load(open(f"{folder}/plaza{n}_s{seed}/metrics.json"))
            for l in m["localizers"]:
                c = l.get("consistency") or {}
                cell = rows.setdefault((n, l["label"]), {}).setdefault(kind, [])
                cell.append((l["position_error_m"]["rms"], c.get("inside_95_ellipse") or 0.0,
                             l["heading_error_deg"]["rms"]))
print(f"{'':22s} {'real RMS':>9s} {'in95':>5s} {'head':>6s} {'twin RMS':>9s} {'in95':>5s} {'head':>6s} {'twin/real':>9s}")
for (n, label), cell in sorted(rows.items()):
    mean = lambda v, k: sum(x[k] for x in v) / len(v)
    r, t = cell["real"], cell["twin"]
    print(f"plaza{n} {label:15s} {mean(r,0):9.3f} {mean(r,1):5.2f} {mean(r,2):6.1f} "
          f"{mean(t,0):9.3f} {mean(t,1):5.2f} {mean(t,2):6.1f} {mean(t,0)/mean(r,0):9.2f}")
EOF
