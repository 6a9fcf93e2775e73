#!/usr/bin/env bash
# Submits a sweep to Slurm (docs/cluster.md): job arrays over the jobs that have no complete result in OUT yet
# (all of them the first time; after a partial failure, only the missing ones) — first one job per sequence, which
# renders the sequence's references into the shared cache, then the others — and a merge job that runs when the
# arrays have ended, however their tasks ended, and writes OUT/sweep.{csv,md} and the plots.
# Usage: scripts/slurm/submit.sh SWEEP.json OUT [restir-sim sweep options ...] [-- sbatch options ...]
#   e.g. scripts/slurm/submit.sh studies/s.json /shared/out/s --cache-dir /shared/cache -- --partition=cpu \
#          --cpus-per-task=4 --time=02:00:00
# Environment: RESTIR_SIM (the binary; default build/release/restir-sim), RESTIR_ARRAY_LIMIT (at most this many
# array tasks at once, Slurm's %N), RESTIR_WARM=0 (no first phase: every job at once), RESTIR_WARM_CPUS (CPUs for
# the first phase's tasks, e.g. a whole node's), RESTIR_SLURM_WAIT=1 (wait for the merge to end; exit with its
# status). Prints the arrays' and the merge's job ids.
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
mkdir -p "$out"
outAbs=$(realpath "$out")
# A job still queued or running has no job.json yet, so it would be planned again and run twice at once.
if squeue -h -o '%k' 2>/dev/null | grep -qxF "restir-sweep:$outAbs"; then
  echo "submit: jobs of $outAbs are still queued or running (squeue); resubmit when they have ended" >&2
  exit 2
fi
# The plan as submitted: each array task runs the job of its index in it, by id (sweep.sbatch).
mkdir -p "$outAbs/plans"
planFile=$outAbs/plans/$(date -u +%Y%m%dT%H%M%S)-$$.jsonl
"$bin" sweep "$sweep" --out "$out" --plan > "$planFile"
export RESTIR_PLAN=$planFile
sbatchOpts=(--comment="restir-sweep:$outAbs" "${sbatchOpts[@]}")
plan=$("$bin" sweep "$sweep" --out "$out" --plan --missing)
wait=()
[ "${RESTIR_SLURM_WAIT:-0}" = 1 ] && wait=(--wait)
if [ -z "$plan" ]; then
  echo "submit: every job of $sweep is complete in $out; submitting the merge only" >&2
  merge=$(sbatch --parsable "${wait[@]}" "${sbatchOpts[@]}" --job-name=restir-merge --cpus-per-task=1 \
          "$here/sweep.sbatch" merge "$sweep" "$out" "${opts[@]}")
  echo "merge ${merge%%;*}"
  exit 0
fi

# Slurm's --array list of the indices on stdin, ranges compressed: 0-3,7,9-10.
array_list() {
  sort -n | awk 'NR == 1 { a = b = $1; next }
                 $1 == b + 1 { b = $1; next }
                 { printf "%s%s,", a, (b > a ? "-" b : ""); a = b = $1 }
                 END { if (NR) printf "%s%s\n", a, (b > a ? "-" b : "") }'
}
# Every job of a sequence needs the same references (they have their own seed). Unless RESTIR_WARM=0, the first
# missing job of each sequence runs first, with RESTIR_WARM_CPUS CPUs if set, and renders them into the shared
# cache; the other jobs start when it has ended and read them, instead of all starting at once and all but one
# waiting on the cache's lock with their CPUs idle.
# "<sequence> <index>" per job of the plan.
pairs=$(printf '%s\n' "$plan" | awk '{ match($0, /"index":[0-9]+/); i = substr($0, RSTART + 8, RLENGTH - 8)
                                       match($0, /"sequence":"[^"]*"/); q = substr($0, RSTART + 12, RLENGTH - 13)
                                       print q, i }')
firstIndices=$(printf '%s\n' "$pairs" | awk '!seen[$1]++ { print $2 }')
first=$(printf '%s\n' "$firstIndices" | array_list)
all=$(printf '%s\n' "$pairs" | awk '{ print $2 }' | array_list)
rest=$(printf '%s\n' "$pairs" | awk '{ print $2 }' | { grep -vxF -f <(printf '%s\n' "$firstIndices") || true; } |
       array_list)
limit=""
[ -n "${RESTIR_ARRAY_LIMIT:-}" ] && limit="%$RESTIR_ARRAY_LIMIT"
dependency=()
if [ "${RESTIR_WARM:-1}" != 0 ] && [ -n "$rest" ]; then
  warmCpus=()
  [ -n "${RESTIR_WARM_CPUS:-}" ] && warmCpus=(--cpus-per-task="$RESTIR_WARM_CPUS")
  warm=$(sbatch --parsable --array="$first$limit" "${sbatchOpts[@]}" "${warmCpus[@]}" \
         "$here/sweep.sbatch" job "$sweep" "$out" "${opts[@]}")
  warm=${warm%%;*}  # "id;cluster" on multi-cluster sites
  echo "array $warm ($first: the first job of each sequence, which renders its references)"
  jobs=$(sbatch --parsable --array="$rest$limit" --dependency="afterany:$warm" "${sbatchOpts[@]}" \
         "$here/sweep.sbatch" job "$sweep" "$out" "${opts[@]}")
  jobs=${jobs%%;*}
  echo "array $jobs ($rest)"
  dependency=(--dependency="afterany:$warm:$jobs")
else
  jobs=$(sbatch --parsable --array="$all$limit" "${sbatchOpts[@]}" "$here/sweep.sbatch" job "$sweep" "$out" \
         "${opts[@]}")
  jobs=${jobs%%;*}
  echo "array $jobs ($all)"
  dependency=(--dependency="afterany:$jobs")
fi
merge=$(sbatch --parsable "${wait[@]}" "${dependency[@]}" "${sbatchOpts[@]}" --job-name=restir-merge \
        --cpus-per-task=1 "$here/sweep.sbatch" merge "$sweep" "$out" "${opts[@]}")
echo "merge ${merge%%;*}"
