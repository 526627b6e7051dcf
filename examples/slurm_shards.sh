#!/usr/bin/env bash
# A scan as a SLURM job array: task K of N runs shard K/N of the scan into OUTDIR/part-K.h5
# (`loosepack run --shard`, README "Long runs"). A task stopped at its time limit saves its
# members first (SLURM sends the script, which execs the program, SIGTERM 120 s before:
# --signal below), and the same array submitted again goes on from each shard's checkpoint.
# When every task has finished:
#   loosepack merge OUTDIR/part-*.h5 -o OUTDIR/all.h5
# which writes the file one run of the whole scan writes. Submit with
#   sbatch --array=0-7 examples/slurm_shards.sh SCAN.toml OUTDIR
# (8 shards here; the shards' count is the array's). The program is `loosepack` on the PATH, or
# $LOOSEPACK.
#SBATCH --job-name=loosepack
#SBATCH --ntasks=1
#SBATCH --cpus-per-task=1
#SBATCH --signal=B:TERM@120
set -euo pipefail
scan=${1:?usage: sbatch --array=0-N examples/slurm_shards.sh SCAN.toml OUTDIR}
outdir=${2:?usage: sbatch --array=0-N examples/slurm_shards.sh SCAN.toml OUTDIR}
k=${SLURM_ARRAY_TASK_ID:?not a task of a SLURM job array}
n=${SLURM_ARRAY_TASK_COUNT:?not a task of a SLURM job array}
part="$outdir/part-$k.h5"
mkdir -p "$outdir"
[ -f "$part" ] && exit 0  # finished by an earlier submission
resume=()
[ -d "$part.checkpoint" ] && resume=(--resume)
# ${resume[@]+...}: an empty array is "unbound" under set -u in bash before 4.4.
exec "${LOOSEPACK:-loosepack}" run "$scan" --shard "$k/$n" -o "$part" ${resume[@]+"${resume[@]}"}
