#!/usr/bin/env bash
# Submits the array of shards and the merge that waits for all of them:
#   RECORDINGS=/data/fleet OUT=/scratch/fleet deploy/slurm/submit.sh
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
: "${RECORDINGS:?}" "${OUT:?}"
mkdir -p "$OUT"
array=$(sbatch --parsable --export=ALL "$here/batch.sbatch")
sbatch --dependency="afterok:${array}" --export=ALL "$here/merge.sbatch"
echo "array job $array; the merge runs when it ends: $OUT/merged/summary.csv"
