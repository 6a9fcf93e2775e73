#!/usr/bin/env bash
# Issue 19's measurement: one study run as one process against the same study as a Slurm job array on this
# machine's single-node test cluster (scripts/slurm/local_cluster.sh), with a cold and a warm reference cache, and
# the fixed cost of a job (an almost empty job, alone and as an array). Prints a markdown table (docs/cluster.md
# quotes it). Needs root and scripts/setup.sh --with-slurm; best on an idle machine.
# Usage: [STUDY_RESOLUTION=320,180] [STUDY_FRAMES=16] scripts/measure_cluster.sh [WORKDIR]
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
bin=$(realpath "${BIN:-build/release/restir-sim}")
W=${1:-$(mktemp -d /tmp/restir-cluster-measure.XXXXXX)}
rm -rf "$W" && mkdir -p "$W" && W=$(realpath "$W")
cores=$(nproc)
now() { date +%s.%N; }
seconds() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", b - a }'; }
# Σ over a sweep's jobs of their wall seconds (job.json) times the threads each ran with (run.json): the work done.
work() {
  local total=0 j wall threads
  for j in $(find "$1/runs" -name job.json); do
    wall=$(sed -n 's/.*"wallSeconds": *\([0-9.eE+-]*\).*/\1/p' "$j")
    threads=$(grep -h '"threads"' "$(dirname "$j")/run.json" | tr -dc '0-9')
    total=$(awk -v t="$total" -v w="$wall" -v n="$threads" 'BEGIN { print t + w * n }')
  done
  awk -v t="$total" 'BEGIN { printf "%.2f", t }'
}

cleanup() { scripts/slurm/local_cluster.sh stop "$W/cluster" >&2 || true; }
trap cleanup EXIT
eval "$(scripts/slurm/local_cluster.sh start "$W/cluster")"

# The study: the flagship at 320x180 (STUDY_RESOLUTION), 16 frames (STUDY_FRAMES), two presets x two seeds = 4 jobs.
res=${STUDY_RESOLUTION:-320,180} frames=${STUDY_FRAMES:-16}
cat > "$W/study.json" <<JSON
{"sequence": "$repo/sequences/window_bars_pan.json", "resolution": [$res], "frames": [0, $frames],
 "referenceSpp": 48, "seeds": [1, 2], "presets": ["restir-unbiased", "restir-spmis"]}
JSON
# The fixed cost of a job: one 8x8 frame at 1 reference sample, 4 jobs.
cat > "$W/empty.json" <<JSON
{"sequence": "$repo/sequences/window_bars_pan.json", "resolution": [8, 8], "frames": [0, 1],
 "referenceSpp": 1, "seeds": [1, 2], "presets": ["ris", "restir-unbiased"]}
JSON

local_sweep() {  # FILE OUT CACHE: one process, every core
  local t0; t0=$(now)
  "$bin" sweep "$1" --out "$2" --cache-dir "$3" --threads "$cores" 2> "$2.log"
  seconds "$t0" "$(now)"
}
array_sweep() {  # FILE OUT CACHE WARM: one-CPU tasks, as many at once as there are cores, then the merge; WARM=1:
                 # the first job of each sequence first, with every core (submit.sh's default first phase)
  local t0; t0=$(now)
  RESTIR_SIM=$bin RESTIR_SLURM_WAIT=1 RESTIR_WARM=$4 RESTIR_WARM_CPUS=$cores \
    scripts/slurm/submit.sh "$1" "$2" --cache-dir "$3" -- \
    --output="$W/slurm-%A_%a.out" --cpus-per-task=1 > "$2.submit.log"
  seconds "$t0" "$(now)"
}

echo "measuring: one process, cold cache" >&2;  a=$(local_sweep "$W/study.json" "$W/local-cold" "$W/cache-local")
echo "measuring: one process, warm cache" >&2;  b=$(local_sweep "$W/study.json" "$W/local-warm" "$W/cache-local")
echo "measuring: array, cold cache, all at once" >&2
c0=$(array_sweep "$W/study.json" "$W/array-cold0" "$W/cache-array0" 0)
echo "measuring: array, cold cache, first phase" >&2
c=$(array_sweep "$W/study.json" "$W/array-cold" "$W/cache-array" 1)
echo "measuring: array, warm cache" >&2;        d=$(array_sweep "$W/study.json" "$W/array-warm" "$W/cache-array" 0)
echo "measuring: empty jobs" >&2
e=$(local_sweep "$W/empty.json" "$W/empty-local" "$W/cache-empty")
f=$(array_sweep "$W/empty.json" "$W/empty-array" "$W/cache-empty" 0)
t0=$(now); "$bin" sweep "$W/empty.json" --out "$W/empty-one" --cache-dir "$W/cache-empty" --job 0 --threads 1 2>/dev/null
g=$(seconds "$t0" "$(now)")
t0=$(now); "$bin" sweep "$W/study.json" --out "$W/local-cold" --merge 2>/dev/null; h=$(seconds "$t0" "$(now)")

same=yes
for o in local-warm array-cold0 array-cold array-warm; do
  diff <(cut -d, -f1-11,16- "$W/local-cold/sweep.csv") <(cut -d, -f1-11,16- "$W/$o/sweep.csv") > /dev/null || same=no
done

cat <<TABLE
| the study (4 jobs: flagship, ${res/,/×}, $frames frames, 2 presets × 2 seeds, 48-spp reference) | wall (s) | work (job wall × threads, s) |
| --- | --- | --- |
| one process, $cores threads, cold cache | $a | $(work "$W/local-cold") |
| one process, $cores threads, warm cache | $b | $(work "$W/local-warm") |
| 4-task array, 1 CPU per task, $cores at once, cold cache, all jobs at once (RESTIR_WARM=0; submission to merged) | $c0 | $(work "$W/array-cold0") |
| the same, first job alone with $cores CPUs, then the other 3 (submit.sh's default) | $c | $(work "$W/array-cold") |
| 4-task array, warm cache | $d | $(work "$W/array-warm") |
| 4 near-empty jobs (one 8×8 frame), one process | $e | $(work "$W/empty-local") |
| the same 4 as an array, submission to merged | $f | $(work "$W/empty-array") |
| one near-empty job as its own process (\`--job 0\`: start, sequence, scene, 1 frame, job.json) | $g | |
| the merge of the study (4 jobs, $frames frames, 2 seeds each: relative errors read) | $h | |

sweep.csv equal to the one-process cold run except timing columns, in every other mode: $same
TABLE
