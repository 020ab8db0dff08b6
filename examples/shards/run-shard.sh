#!/usr/bin/env bash
# Run shard K of N of a clusterlab variant matrix into $OUT/shard-K.
#
#   examples/shards/run-shard.sh K N        # by hand, or from a CI matrix job
#   sbatch --array=1-N examples/slurm/matrix-shard.sbatch   # K and N from Slurm
#
# Environment:
#   CLUSTERLAB              the clusterlab binary (default: clusterlab on PATH)
#   OUT                     where the shard folders go (default: out/shards)
#   CLUSTERLAB_MATRIX_ARGS  extra `clusterlab matrix` arguments, the same for every shard
#                           (default: none, the default matrix)
# Every shard must run with the same arguments, variant files and adapter kind: `merge`
# refuses shards from different adapters or variant files.
set -euo pipefail

K="${1:-${SLURM_ARRAY_TASK_ID:-}}"
N="${2:-${SLURM_ARRAY_TASK_COUNT:-}}"
if [[ -z "$K" || -z "$N" ]]; then
    echo "usage: $0 K N (or run as a Slurm array job, which sets both)" >&2
    exit 2
fi
CLUSTERLAB="${CLUSTERLAB:-clusterlab}"
OUT="${OUT:-out/shards}"
# Word splitting is wanted: the variable holds several arguments.
# shellcheck disable=SC2086
exec "$CLUSTERLAB" matrix --shard "$K/$N" --out "$OUT/shard-$K" ${CLUSTERLAB_MATRIX_ARGS:-}
