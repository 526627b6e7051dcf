#!/usr/bin/env bash
# A scan as a SLURM job array: task K of N runs shard K/N of the scan into OUTDIR/part-K.h5
# (`loosepack run --shard`, README "Long runs"). A task stopped at its time limit saves its
# members first (SLURM sends the script, which execs the program, SIGTERM 120 s before:
# --signal below), and the same array submitted again goes on from each shard's checkpoint.
# When every task has finished:
#   loosepack merge OUTDIR/part-*.h5 -o OUTDIR/all.h5
# which writes the file one run of the whole scan writes. Submit with
#   sbatch --array=0-7 examples/slurm_shards.sh SCAN.toml OUTDIR 8
# (8 shards: N, the last argument, is the shards' count, so that some tasks alone can be
# submitted again, `--array=3,5`, and still run their shards of 8). A part whose checkpoint is
# still there (stopped, or written with `--resume --finished-only`) goes on from it; a part
# without one is finished, and its task does nothing. The program is `loosepack` on the PATH, or
# $LOOSEPACK.
#SBATCH --job-name=loosepack
#SBATCH --ntasks=1
#SBATCH --cpus-per-task=1
#SBATCH --signal=B:TERM@120
set -euo pipefail
usage="usage: sbatch --array=0-(N-1) examples/slurm_shards.sh SCAN.toml OUTDIR N"
scan=${1:?$usage}
outdir=${2:?$usage}
n=${3:?$usage}
k=${SLURM_ARRAY_TASK_ID:?not a task of a SLURM job array}
if ! [[ $n =~ ^[1-9][0-9]*$ ]] || [ "$k" -ge "$n" ]; then
  echo "slurm_shards.sh: task $k of $n shards: N must be a count above every task's index; $usage" >&2
  exit 2
fi
part="$outdir/part-$k.h5"
mkdir -p "$outdir"
if [ -d "$part.checkpoint" ]; then  # stopped, or written with --finished-only: go on
  exec "${LOOSEPACK:-loosepack}" run "$scan" --shard "$k/$n" -o "$part" --resume --force
fi
[ -f "$part" ] && exit 0  # finished by an earlier submission
exec "${LOOSEPACK:-loosepack}" run "$scan" --shard "$k/$n" -o "$part"
