#!/usr/bin/env bash
# A sharded icp-eval run on Slurm: an array of N tasks, each running its part of the job list
# (icp-eval reads SLURM_ARRAY_TASK_ID − SLURM_ARRAY_TASK_MIN of SLURM_ARRAY_TASK_COUNT, says
# which shard it runs, and writes $OUT/part/<task>/part-K-of-N.cbor), then a merge job that
# starts when every task has succeeded and writes the single run's files into $OUT/merged.
#
# Submit from a login node (not itself an sbatch script, so the array size is set once):
#   OUT=/scratch/$USER/sweep N=16 scripts/slurm-array.sh compare --dataset carmen:/data/aces.log.gz \
#     --variants H_ICP,HD_ICP,PL_ICP --sweep huber_c=1,2.0138,3
# Everything after the script's name is the icp-eval command (run, compare or basin) without
# --out; use absolute dataset paths (the merge re-loads the dataset from shard 0's command
# line and checks it against the plan's file hashes). Not run here: no Slurm on this machine;
# the same shards and merge are exercised with xargs by eval/tests/shard.rs.
set -euo pipefail
: "${OUT:?set OUT to a shared output directory}"
N="${N:-8}"
ICP_EVAL="${ICP_EVAL:-icp-eval}"
CPUS="${CPUS:-4}"
if [ "$#" -eq 0 ]; then
  echo "usage: OUT=DIR [N=8] $0 run|compare|basin ARGS... (without --out)" >&2
  exit 2
fi
mkdir -p "$OUT/logs"
args=$(printf '%q ' "$@")

array_job=$(sbatch --parsable \
  --job-name=icp-eval-shard \
  --array="0-$((N - 1))" \
  --cpus-per-task="$CPUS" \
  --time=04:00:00 \
  --output="$OUT/logs/shard-%a.out" \
  --wrap="$ICP_EVAL $args --threads $CPUS --quiet --out $OUT/part/\$SLURM_ARRAY_TASK_ID")

sbatch --parsable \
  --job-name=icp-eval-merge \
  --dependency="afterok:$array_job" \
  --cpus-per-task=1 \
  --time=00:30:00 \
  --output="$OUT/logs/merge.out" \
  --wrap="$ICP_EVAL merge $OUT/part/* --quiet --out $OUT/merged"
echo "submitted array $array_job ($N shards) and its merge; results in $OUT/merged"
