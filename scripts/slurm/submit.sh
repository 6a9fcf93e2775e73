#!/usr/bin/env bash
# Submits a sweep to Slurm (docs/cluster.md): a job array over the jobs that have no complete result in OUT yet
# (all of them the first time; after a partial failure, only the missing ones), then a merge job that runs when
# the array has ended, however its tasks ended, and writes OUT/sweep.{csv,md} and the plots.
# Usage: scripts/slurm/submit.sh SWEEP.json OUT [restir-sim sweep options ...] [-- sbatch options ...]
#   e.g. scripts/slurm/submit.sh studies/s.json /shared/out/s --cache-dir /shared/cache -- --partition=cpu \
#          --cpus-per-task=4 --time=02:00:00
# Environment: RESTIR_SIM (the binary; default build/release/restir-sim), RESTIR_ARRAY_LIMIT (at most this many
# array tasks at once, Slurm's %N), RESTIR_SLURM_WAIT=1 (wait for the merge to end; exit with its status).
# Prints the array's and the merge's job ids.
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: scripts/slurm/submit.sh SWEEP.json OUT [restir-sim sweep options] [-- sbatch options]" >&2
  exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
bin=${RESTIR_SIM:-build/release/restir-sim}
sweep=$1 out=$2
shift 2
opts=() sbatchOpts=()
while [ $# -gt 0 ]; do
  if [ "$1" = -- ]; then shift; sbatchOpts=("$@"); break; fi
  opts+=("$1"); shift
done
export RESTIR_SIM=$(realpath "$bin")
array=$("$bin" sweep "$sweep" --out "$out" --plan --missing --format array)
wait=()
[ "${RESTIR_SLURM_WAIT:-0}" = 1 ] && wait=(--wait)
if [ -z "$array" ]; then
  echo "submit: every job of $sweep is complete in $out; submitting the merge only" >&2
  merge=$(sbatch --parsable "${wait[@]}" "${sbatchOpts[@]}" --job-name=restir-merge --cpus-per-task=1 \
          "$here/sweep.sbatch" merge "$sweep" "$out" "${opts[@]}")
  echo "merge ${merge%%;*}"
  exit 0
fi
[ -n "${RESTIR_ARRAY_LIMIT:-}" ] && array="$array%$RESTIR_ARRAY_LIMIT"
jobs=$(sbatch --parsable --array="$array" "${sbatchOpts[@]}" "$here/sweep.sbatch" job "$sweep" "$out" "${opts[@]}")
jobs=${jobs%%;*}  # "id;cluster" on multi-cluster sites
echo "array $jobs ($array)"
merge=$(sbatch --parsable "${wait[@]}" --dependency="afterany:$jobs" "${sbatchOpts[@]}" --job-name=restir-merge \
        --cpus-per-task=1 "$here/sweep.sbatch" merge "$sweep" "$out" "${opts[@]}")
echo "merge ${merge%%;*}"
