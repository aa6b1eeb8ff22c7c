#!/usr/bin/env bash
# The real logs of MRCLAM Dataset 6 against their twins with and without each modelled effect
# (README.md, "Real against twin"). Calibrates all five robots' 900 s, writes five calibration
# files that differ only in what the twin is given (none; the depth range model; the command
# response; both; all: both with the gains' wander, the detections' slow part, range and
# bearing errors each their own, the wheels' errors correlated, the camera's blind spells, its
# misses growing with range, each robot's camera where its bearings say it is, and the body's
# side slip) and one per robot (own: all,
# from that robot's log alone), makes 5 robots x 3 seeds of twin recordings for each, and sweeps
# the five landmark filters and dead reckoning over the real logs (3 filter seeds) and each set of
# twins, with the calibration's localizer parameters. Prints the table of the README.
#
#   MRCLAM_DIR=/path/to/MRCLAM_Dataset6 [OUT=/tmp/s2r] [LOCSIM=build/locsim] ./twin_models.sh
#
# About 6 minutes on the 2-core VM. Needs pandas (for the table only).
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=mrclam_logs.sh
source "$HERE/mrclam_logs.sh" /tmp/s2r
"$LOCSIM" calibrate ds6.locsimlog --out cal6 --overwrite

# The variants: the calibration file with the twin's models taken out one at a time. Without the
# response the encoders get the raw odometry's k; without the depth model the camera gets the
# distance model's lines (both from calibration.json); without "all" the robot's gains do not
# wander, the camera's errors have one time constant for range and bearing (the single one
# calibration.json fits), the wheels' errors are independent, the cameras are never blind, miss
# as often at every range and are where their detections are given from.
"${PYTHON:-python3}" - <<'PY'
import json, math, re
text = open("cal6/calibration.yaml").read()
fits = json.load(open("cal6/calibration.json"))
motion = fits["motion"]["wheel_model"]
distance = fits["cameras"][0]["range_models"]["distance"]
raw_encoders = f"  encoders: {{k_left: {motion['k_left']:.4g}, k_right: {motion['k_right']:.4g}}}"
distance_lines = (f"    range_model: distance\n    sigma_range_m: {distance['spread']['m']:.4g}\n"
                  f"    sigma_range_per_m: {distance['spread']['per_m']:.4g}\n"
                  f"    range_bias_m: {distance['bias']['m']:.4g}\n"
                  f"    range_bias_per_m: {distance['bias']['per_m']:.4g}\n")
depth_lines = re.search(r"    range_model: depth\n(    .*\n){4}", text).group(0)
single_tau = fits["cameras"][0]["noise_correlation"]["tau_s"]
def variant(response, depth, rest):
    t = text
    if not rest:
        t = re.sub(r", gain_wander_v: [^,]*, gain_wander_omega: [^,]*, gain_wander_correlation_s: [^}]*",
                   "", t)
        t = re.sub(r"    noise_correlation_s: .*\n    noise_correlation_slow_s: .*\n"
                   r"    noise_correlation_slow_share: .*\n",
                   f"    noise_correlation_s: {single_tau:.4g}\n", t)
        t = re.sub(r"    bearing_noise_correlation_.*\n", "", t)
        # The cameras never blind, at their believed places, with the bearings' noise measured
        # from there.
        t = re.sub(r"    outage_fraction: .*\n    outage_mean_s: .*\n", "", t)
        # Misses independent of range, at the rate over all the readings.
        t = re.sub(r"    miss_probability: .*\n    detection_decay_m: .*\n",
                   f"    miss_probability: {fits['cameras'][0]['miss_probability']:.4g}\n", t)
        t = re.sub(r"camera_offsets:.*\n(  .*\n)*", "", t)
        # The body held to its heading.
        t = re.sub(r"  # the body slides.*\n  side_slip: .*\n", "", t)
        camera = fits["cameras"][0]
        t = re.sub(r"    sigma_bearing_deg: .*\n",
                   f"    sigma_bearing_deg: {math.degrees(camera['bearing_spread_rad']):.4g}\n", t)
        t = re.sub(r"    bearing_bias_deg: .*\n",
                   f"    bearing_bias_deg: {math.degrees(camera['bearing_bias_rad']):.4g}\n", t)
        response_k = fits["motion"].get("command_response", {})
        if "k_left" in response_k:
            t = re.sub(r"  encoders: \{measures: command, .*\}",
                       f"  encoders: {{measures: command, k_left: {response_k['k_left']:.4g}, "
                       f"k_right: {response_k['k_right']:.4g}}}", t)
    if not response:
        t = re.sub(r"  # the motion lags.*\n  command_response: .*\n", "", t)
        t = re.sub(r"  encoders: \{.*\}", raw_encoders, t)
    if not depth:
        t = t.replace(depth_lines, distance_lines)
    return re.sub(r"robot: .*\n(?!  )", "", t)  # a robot: section left empty
for name, response, depth, rest in (("none", False, False, False), ("depth", False, True, False),
                                    ("response", True, False, False), ("both", True, True, False),
                                    ("all", True, True, True)):
    open(f"cal_{name}.yaml", "w").write(variant(response, depth, rest))
PY

localizers="localizers:
  - plugin: odometry
$landmark_filters
timeout_s: 600"
cat > real.yaml <<EOF
name: mrclam_ds6_real
logs: [ds6_r1.locsimlog, ds6_r2.locsimlog, ds6_r3.locsimlog, ds6_r4.locsimlog, ds6_r5.locsimlog]
seeds: {from: 1, to: 3}
params_file: cal6/calibration.yaml
$localizers
EOF
rm -rf runs && mkdir runs
"$LOCSIM" sweep real.yaml --jobs 2 --out runs/real > /dev/null
for n in 1 2 3 4 5; do
  "$LOCSIM" calibrate ds6_r$n.locsimlog --out cal_own_r$n --overwrite -q
done
for v in none depth response both all own; do
  mkdir -p twin_$v
  logs=""
  for n in 1 2 3 4 5; do
    calibration=cal_$v.yaml
    [ $v = own ] && calibration=cal_own_r$n/calibration.yaml
    "$LOCSIM" twin ds6_r$n.locsimlog --calibration $calibration --out twin_$v/ds6_r$n.yaml --overwrite > /dev/null
    for s in 1 2 3; do
      "$LOCSIM" run twin_$v/ds6_r$n.yaml --seed $s --log twin_$v/ds6_r${n}_s$s.locsimlog \
        --out twin_$v/run_r${n}_s$s --no-readings -q --overwrite
      logs="$logs${logs:+, }twin_$v/ds6_r${n}_s$s.locsimlog"
    done
  done
  # No seeds: each twin run's localizers take its recording's seed.
  printf 'name: mrclam_ds6_twin_%s\nlogs: [%s]\nparams_file: cal6/calibration.yaml\n%s\n' \
    "$v" "$logs" "$localizers" > twin_$v.yaml
  "$LOCSIM" sweep twin_$v.yaml --jobs 2 --out runs/twin_$v > /dev/null
done
# "together": the five robots twinned in one world from the whole log (all models), where each
# robot's body hides landmarks from the others' cameras as the real robots' do.
mkdir -p twin_together
"$LOCSIM" twin ds6.locsimlog --calibration cal_all.yaml --out twin_together/ds6.yaml --overwrite > /dev/null
logs=""
for s in 1 2 3; do
  "$LOCSIM" run twin_together/ds6.yaml --seed $s --log twin_together/ds6_s$s.locsimlog \
    --out twin_together/run_s$s --no-readings -q --overwrite
  logs="$logs${logs:+, }{file: twin_together/ds6_s$s.locsimlog, robots: [robot1, robot2, robot3, robot4, robot5]}"
done
printf 'name: mrclam_ds6_twin_together\nlogs: [%s]\nparams_file: cal6/calibration.yaml\n%s\n' \
  "$logs" "$localizers" > twin_together.yaml
"$LOCSIM" sweep twin_together.yaml --jobs 2 --out runs/twin_together > /dev/null
"$LOCSIM" compare runs/real runs/twin_all --out runs/real_vs_twin --labels real,twin > /dev/null

"${PYTHON:-python3}" - <<'PY'
import pandas as pd
sets = [("real", "runs/real"), ("twin, none", "runs/twin_none"), ("twin, depth", "runs/twin_depth"),
        ("twin, response", "runs/twin_response"), ("twin, both", "runs/twin_both"),
        ("twin, all", "runs/twin_all"), ("twin, own robot", "runs/twin_own"),
        ("twin, all, together", "runs/twin_together")]
filters = ["ekf_landmarks", "mcl", "srl", "asrl", "augmented_mcl"]
real = pd.read_csv("runs/real/summary.csv").set_index("config")
print("| set | config | position RMS [m] | x real | heading RMS [deg] | truth in 95 % ellipse | median NEES |")
print("|---|---|---|---|---|---|---|")
for name, path in sets:
    d = pd.read_csv(f"{path}/summary.csv").set_index("config")
    for c in filters:
        r = d.loc[c]
        print(f"| {name} | {c} | {r.position_rms_m_mean:.3f} ± {r.position_rms_m_ci95:.3f} | "
              f"{r.position_rms_m_mean / real.loc[c, 'position_rms_m_mean']:.2f} | "
              f"{r.heading_rms_deg_mean:.1f} | {r.inside_95_ellipse_mean:.2f} | {r.nees_median:.1f} |")
PY
grep -m1 "Kendall" runs/real_vs_twin/report.md
