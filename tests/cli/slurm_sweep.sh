#!/usr/bin/env bash
# Issue 19's proof against a real Slurm: a single-node cluster on localhost (scripts/slurm/local_cluster.sh:
# munged, slurmctld and slurmd started directly, no systemd) runs a small sweep as a job array through
# scripts/slurm/submit.sh, then the dependent merge; the merged sweep must equal the same sweep run in one local
# process, byte for byte except the timing columns, and so must every job's metrics (timings aside) and
# relative-error frames. Then a partially failed array is resumed: two jobs' results are withdrawn, the
# resubmission runs exactly those two, and the merge is whole again. The cluster is torn down by its daemons' PIDs.
#
#   tests/cli/slurm_sweep.sh BINARY [WORKDIR]
#
# Needs root (slurmd runs as root) and Debian's slurmctld, slurmd, slurm-client and munge (scripts/setup.sh
# --with-slurm). Without them it exits 77, which ctest reports as skipped, unless RESTIR_REQUIRE_SLURM=1 (CI),
# where their absence is a failure.
set -euo pipefail
BIN=$(realpath "$1")
cd "$(dirname "$0")/../.."
repo=$(pwd)
# Everything goes to a fresh directory inside WORKDIR (nothing else in WORKDIR is touched).
base=${2:-$(mktemp -d /tmp/restir-slurm.XXXXXX)}
mkdir -p "$base"
W=$(realpath "$base")/slurm-sweep-test
rm -rf "$W"
mkdir -p "$W"

missing=()
for tool in munged slurmctld slurmd sbatch squeue sinfo; do command -v "$tool" >/dev/null || missing+=("$tool"); done
if [ ${#missing[@]} -gt 0 ] || [ "$(id -u)" -ne 0 ]; then
  why="missing ${missing[*]:-nothing}; uid $(id -u)"
  if [ "${RESTIR_REQUIRE_SLURM:-0}" = 1 ]; then
    echo "FAIL: no Slurm to test against ($why): scripts/setup.sh --with-slurm installs it; run as root" >&2
    exit 1
  fi
  echo "SKIP: no Slurm to test against ($why); scripts/setup.sh --with-slurm installs it" >&2
  exit 77
fi

cluster=$W/cluster
seconds() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", b - a }'; }
cleanup() { scripts/slurm/local_cluster.sh stop "$cluster" >&2 || true; }
trap cleanup EXIT
t0=$(date +%s.%N)
started=$(scripts/slurm/local_cluster.sh start "$cluster")  # set -e: a failed start ends the test here
eval "$started"
[ -n "${SLURM_CONF:-}" ] || { echo "FAIL: the cluster's start printed no SLURM_CONF"; exit 1; }
t1=$(date +%s.%N)
echo "cluster up in $(seconds "$t0" "$t1") s ($SLURM_CONF)"
sinfo >&2

# 1 sequence x 2 configurations x 2 seeds = 4 jobs, plus a second sequence's 4: 8 jobs, two at once on 2 CPUs.
cat > "$W/study.json" <<JSON
{
  "sequences": ["$repo/sequences/smoke.json", "$repo/sequences/hard/camera_cut.json"],
  "resolution": [64, 36], "frames": [0, 4], "referenceSpp": 32, "seeds": [5, 6],
  "presets": ["restir-unbiased"],
  "configs": [{"name": "ris8", "preset": "ris", "set": {"initial.candidates": 8}}]
}
JSON

"$BIN" sweep "$W/study.json" --out "$W/local" --cache-dir "$W/cache-local" --threads 2 2> "$W/local.log"
jobs=$("$BIN" sweep "$W/study.json" --out "$W/slurm" --plan --format index | wc -l)
[ "$jobs" -eq 8 ] || { echo "FAIL: plan has $jobs jobs, expected 8"; exit 1; }

submit() {  # the sweep's missing jobs as an array, then the merge; waits for the merge (10 min at most)
  RESTIR_SIM=$BIN RESTIR_SLURM_WAIT=1 timeout 600 scripts/slurm/submit.sh "$W/study.json" "$W/slurm" \
    --cache-dir "$W/cache-shared" -- --output="$W/slurm-%A_%a.out" --time=10
}
s0=$(date +%s.%N)
submit > "$W/submit.log"
s1=$(date +%s.%N)
cat "$W/submit.log"
echo "array and merge done in $(seconds "$s0" "$s1") s"

# The columns that are timings, or follow from them, are left out of the comparison, and reference_cached, which
# says whether this process rendered the frame's reference or read another's from the cache.
drop_timings() {  # FILE: the CSV without ms_*, efficiency, pareto and reference_cached columns
  awk -F, 'NR == 1 { for (i = 1; i <= NF; i++)
                       keep[i] = !($i ~ /^ms_/ || $i == "efficiency" || $i == "pareto" || $i == "reference_cached") }
           { line = ""; for (i = 1; i <= NF; i++) if (keep[i]) line = line $i ","; print line }' "$1"
}
fail=0
compare() {  # what: a label
  if ! diff <(drop_timings "$W/local/sweep.csv") <(drop_timings "$W/slurm/sweep.csv") > "$W/diff.txt"; then
    echo "FAIL ($1): merged sweep.csv differs from the local one:"; cat "$W/diff.txt"; fail=1
  fi
  while read -r dir; do
    for f in metrics.csv relative_error.bin; do
      if [ "$f" = metrics.csv ]; then
        cmp -s <(drop_timings "$W/local/$dir/$f") <(drop_timings "$W/slurm/$dir/$f") ||
          { echo "FAIL ($1): $dir/$f differs"; fail=1; }
      else
        cmp -s "$W/local/$dir/$f" "$W/slurm/$dir/$f" || { echo "FAIL ($1): $dir/$f differs"; fail=1; }
      fi
    done
  done <<< "$dirs"
}
dirs=$("$BIN" sweep "$W/study.json" --plan | sed 's/.*"dir":"\([^"]*\)".*/\1/')
[ "$(printf '%s\n' "$dirs" | grep -c '^runs/')" -eq 8 ] || { echo "FAIL: the plan's directories: $dirs"; exit 1; }
[ -s "$W/slurm/sweep.csv" ] || { echo "FAIL: the merge job wrote no sweep.csv"; ls -R "$W/slurm" | head; exit 1; }
compare "first submission"
# Array tasks' logs are slurm-<array>_<task>.out with a task index below 8 (the merge's %a is not one).
tasks=$(ls "$W"/slurm-*_[0-7].out 2>/dev/null | wc -l)
[ "$tasks" -eq 8 ] || { echo "FAIL: $tasks array task logs, expected 8"; fail=1; }
grep -q "merged 8 of 8 jobs" "$W"/slurm-*.out || { echo "FAIL: no merge log saying 8 of 8"; fail=1; }

# A partially failed array: two jobs lost their results. The plan lists exactly those; the resubmission runs them.
rm "$W/slurm/runs/smoke/ris8/seed-6/job.json" "$W/slurm/runs/camera_cut/restir-unbiased/seed-5/job.json"
rm "$W"/slurm-*.out
missing=$("$BIN" sweep "$W/study.json" --out "$W/slurm" --plan --missing --format array)
[ "$missing" = "3-4" ] || { echo "FAIL: --plan --missing gave '$missing', expected 3-4"; fail=1; }
"$BIN" sweep "$W/study.json" --out "$W/slurm" --merge 2> "$W/partial.log"
grep -q "merged 6 of 8 jobs.*2 missing: smoke/ris8/seed-6 camera_cut/restir-unbiased/seed-5" "$W/partial.log" ||
  { echo "FAIL: the partial merge did not name the missing jobs:"; cat "$W/partial.log"; fail=1; }
submit > "$W/resubmit.log"
cat "$W/resubmit.log"
grep -q "^array [0-9]* (3-4)$" "$W/resubmit.log" || { echo "FAIL: the resubmission was not the array 3-4"; fail=1; }
compare "after resuming"

if [ "$fail" -ne 0 ]; then
  echo "--- slurmctld log"; tail -20 "$cluster"/*ctld*.log 2>/dev/null || true
  exit 1
fi
echo "PASS: the Slurm array's merge equals the local sweep (timings aside); resuming reran exactly the missing jobs"
