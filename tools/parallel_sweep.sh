#!/usr/bin/env bash
# A locsim sweep spread over machines with GNU parallel and ssh (each host needs locsim built at
# the same path and a shared or synced folder), then merged:
#
#   tools/parallel_sweep.sh EXPERIMENT.yaml OUT 8 host1,host2,host3
#
# The one line that does it, to adapt:
#   seq 1 8 | parallel -S host1,host2 --workdir "$PWD" build/locsim sweep EXP --shard {}/8 --out OUT/shard-{}
set -euo pipefail
experiment=$1
out=$2
shards=$3
hosts=${4:-:}   # ":" is GNU parallel's name for this machine
# Every shard runs to its end: one whose runs ended in error exits with 1 but holds all its other
# results (a --resume of it runs the errored ones again); bad input or a missing plugin fails every
# shard at once (exit 2, 3), before anything is simulated.
status=0
seq 1 "$shards" | parallel -S "$hosts" --workdir "$PWD" \
  build/locsim sweep "$experiment" --shard "{}/$shards" --out "$out/shard-{}" || status=$?
build/locsim merge "$out/merged" "$out"/shard-*
exit "$status"
