#!/usr/bin/env bash
# Submit the variant matrix as a Slurm job array of N shards and a merge that runs once they
# have all succeeded:
#
#   CLUSTERLAB=$PWD/target/release/clusterlab examples/slurm/submit.sh 8
#
# The report lands in $OUT/merged (default out/shards/merged); pass extra matrix arguments
# in CLUSTERLAB_MATRIX_ARGS (e.g. "--sweep lights=1024,4096,16384").
set -euo pipefail
N="${1:?usage: $0 SHARDS}"
mkdir -p out/slurm
export CLUSTERLAB="${CLUSTERLAB:-clusterlab}" OUT="${OUT:-out/shards}" CLUSTERLAB_MATRIX_ARGS="${CLUSTERLAB_MATRIX_ARGS:-}"
array=$(sbatch --parsable --export=ALL --array="1-$N" examples/slurm/matrix-shard.sbatch)
sbatch --export=ALL --dependency="afterok:$array" examples/slurm/merge.sbatch
echo "queued shards as job $array and the merge after them; report: $OUT/merged/index.html"
