#!/usr/bin/env bash
# One recording's calibration on another (README.md, "One recording's calibration on another"):
# `locsim calibrate` with several logs, on MRCLAM Dataset 6 cut two ways: its two halves (all five
# robots, 450 s each) and its five robots (one log each). The five landmark filters replay every
# recording with every recording's calibration and the pooled one, three seeds each; the flags
# name the group of parameters that moves each flagged cell.
#
#   MRCLAM_DIR=/path/to/MRCLAM_Dataset6 [OUT=/tmp/s2r_transfer] [LOCSIM=build/locsim] ./transfer.sh
#
# About 15 minutes on the 2-core VM.
set -euo pipefail
HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=mrclam_logs.sh
source "$HERE/mrclam_logs.sh" /tmp/s2r_transfer
[ -f first.locsimlog ] || "$LOCSIM" import mrclam "$MRCLAM_DIR" --duration 450 --out first.locsimlog -q
[ -f second.locsimlog ] || "$LOCSIM" import mrclam "$MRCLAM_DIR" --from 450 --duration 450 --out second.locsimlog -q
filters=ekf_landmarks,mcl,srl,asrl,augmented_mcl
echo "== the two halves"
"$LOCSIM" calibrate first.locsimlog second.locsimlog --out halves --check $filters --check-seeds 3 --jobs 2 --overwrite
echo "== the five robots"
"$LOCSIM" calibrate ds6_r1.locsimlog ds6_r2.locsimlog ds6_r3.locsimlog ds6_r4.locsimlog ds6_r5.locsimlog \
  --out robots --check $filters --check-seeds 3 --jobs 2 --overwrite
