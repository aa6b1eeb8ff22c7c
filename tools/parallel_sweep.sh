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
seq 1 "$shards" | parallel -S "$hosts" --workdir "$PWD" --halt now,fail=1 \
  build/locsim sweep "$experiment" --shard "{}/$shards" --out "$out/shard-{}"
build/locsim merge "$out/merged" "$out"/shard-*
