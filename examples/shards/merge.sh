#!/usr/bin/env bash
# Merge every shard folder under $OUT (from run-shard.sh) into $OUT/merged: one report,
# as if the matrix had run on one machine.
#
# Environment: CLUSTERLAB and OUT as for run-shard.sh.
set -euo pipefail

CLUSTERLAB="${CLUSTERLAB:-clusterlab}"
OUT="${OUT:-out/shards}"
shopt -s nullglob
shards=("$OUT"/shard-*)
if [[ ${#shards[@]} -eq 0 ]]; then
    echo "no shard folders under $OUT (run run-shard.sh first)" >&2
    exit 2
fi
exec "$CLUSTERLAB" merge "${shards[@]}" --out "$OUT/merged"
