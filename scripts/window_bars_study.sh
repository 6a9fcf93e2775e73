#!/usr/bin/env bash
# The stochastic pairwise MIS study (seed 004) behind docs/studies/window_bars.md: restir-spmis, restir-unbiased and
# restir-biased on the disocclusion sequences at 640x360, run as one sweep (docs/sweep-format.md), then the
# generated document.
# Usage: [SEEDS=N] [SLURM=1] scripts/window_bars_study.sh [SEQUENCE.json ...]
#   (default: the flagship, the camera cut and the exterior flagship; SEEDS: seeds per configuration from each sequence's own, default 1,
#   with 2 or more relmse_disocc gets its interval; SLURM=1: run the jobs as Slurm arrays through
#   scripts/slurm/submit.sh and wait for the merge — docs/cluster.md — instead of in this process)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-build/release/restir-sim}
seqs=("$@")
if [ ${#seqs[@]} -eq 0 ]; then
  seqs=(sequences/window_bars_pan.json)
  [ -f sequences/hard/camera_cut.json ] && seqs+=(sequences/hard/camera_cut.json)
  seqs+=(sequences/sun_street_pan.json)
fi
out=out/study
mkdir -p "$out"
sequences=""
for s in "${seqs[@]}"; do sequences+="${sequences:+, }\"$(realpath "$s")\""; done
# name, preset, settings
cat > "$out/window_bars.json" <<JSON
{
  "sequences": [$sequences],
  "resolution": [640, 360],
  "seedCount": ${SEEDS:-1},
  "configs": [
    {"name": "biased-k5", "preset": "restir-biased"},
    {"name": "unbiased-k3", "preset": "restir-unbiased",
     "set": {"spatial.neighbours": 3, "spatial.disocclusionNeighbours": 6}},
    {"name": "unbiased-k5", "preset": "restir-unbiased"},
    {"name": "unbiased-k8", "preset": "restir-unbiased",
     "set": {"spatial.neighbours": 8, "spatial.disocclusionNeighbours": 15}},
    {"name": "spmis-N2", "preset": "restir-spmis", "set": {"spatial.draws": 2, "spatial.canonicalDraws": 2}},
    {"name": "spmis-N3", "preset": "restir-spmis", "set": {"spatial.draws": 3, "spatial.canonicalDraws": 3}},
    {"name": "spmis-N5", "preset": "restir-spmis"},
    {"name": "spmis-N8", "preset": "restir-spmis", "set": {"spatial.draws": 8, "spatial.canonicalDraws": 8}},
    {"name": "spmis-N5-noscale", "preset": "restir-spmis", "set": {"spatial.confidenceScaling": false}}
  ]
}
JSON
if [ "${SLURM:-0}" = 1 ]; then
  RESTIR_SIM=$bin RESTIR_SLURM_WAIT=1 scripts/slurm/submit.sh "$out/window_bars.json" "$out"
else
  "$bin" sweep "$out/window_bars.json" --out "$out"
fi
dirs=()
while read -r d; do dirs+=("$out/$d"); done < <("$bin" sweep "$out/window_bars.json" --plan |
                                                sed 's/.*"dir":"\([^"]*\)".*/\1/')
mkdir -p docs/studies
scripts/make_window_bars_study.py "${dirs[@]}" > docs/studies/window_bars.md.tmp
mv docs/studies/window_bars.md.tmp docs/studies/window_bars.md
echo "wrote docs/studies/window_bars.md (the sweep's own tables: $out/sweep.md)" >&2
