# Sourced by twin_models.sh and cross_robot.sh: checks MRCLAM_DIR, finds locsim ($LOCSIM or the
# build's), makes and enters $OUT (default: the first argument), and imports Dataset 6 there as
# one log of all five robots (ds6.locsimlog) and one per robot (ds6_rN.locsimlog), once.
if [ -z "${MRCLAM_DIR:-}" ]; then
  echo "MRCLAM_DIR is not set: the extracted MRCLAM_Dataset6 folder of the UTIAS MRCLAM benchmark" >&2
  echo "(http://asrl.utias.utoronto.ca/datasets/mrclam/)." >&2
  exit 2
fi
LOCSIM=$(realpath "${LOCSIM:-$HERE/../../../../build/locsim}")
OUT=${OUT:-$1}
mkdir -p "$OUT"
cd "$OUT"
for n in 1 2 3 4 5; do
  [ -f ds6_r$n.locsimlog ] || "$LOCSIM" import mrclam "$MRCLAM_DIR" --robots $n --out ds6_r$n.locsimlog -q
done
[ -f ds6.locsimlog ] || "$LOCSIM" import mrclam "$MRCLAM_DIR" --out ds6.locsimlog -q

# The five landmark filters the reports compare, as entries of an experiment's `localizers:`.
landmark_filters='  - plugin: ekf_landmarks
  - plugin: mcl
  - plugin: srl
  - plugin: asrl
  - plugin: augmented_mcl'
