#!/usr/bin/env bash
# The stochastic pairwise MIS study (seed 004) behind docs/studies/window_bars.md: a sweep of restir-spmis,
# restir-unbiased and restir-biased on the disocclusion sequences at 640x360, then the generated document.
# Usage: scripts/window_bars_study.sh [SEQUENCE.json ...]   (default: the flagship and the camera cut)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-build/release/restir-sim}
seqs=("$@")
if [ ${#seqs[@]} -eq 0 ]; then
  seqs=(sequences/window_bars_pan.json)
  [ -f sequences/hard/camera_cut.json ] && seqs+=(sequences/hard/camera_cut.json)
fi
# name|preset|overrides (space-separated KEY=VALUE)
configs=(
  "biased-k5|restir-biased|"
  "unbiased-k3|restir-unbiased|spatial.neighbours=3 spatial.disocclusionNeighbours=6"
  "unbiased-k5|restir-unbiased|"
  "unbiased-k8|restir-unbiased|spatial.neighbours=8 spatial.disocclusionNeighbours=15"
  "spmis-N2|restir-spmis|spatial.draws=2 spatial.canonicalDraws=2"
  "spmis-N3|restir-spmis|spatial.draws=3 spatial.canonicalDraws=3"
  "spmis-N5|restir-spmis|"
  "spmis-N8|restir-spmis|spatial.draws=8 spatial.canonicalDraws=8"
  "spmis-N5-noscale|restir-spmis|spatial.confidenceScaling=false"
)
dirs=()
for s in "${seqs[@]}"; do
  name=$(basename "$s" .json)
  for c in "${configs[@]}"; do
    IFS='|' read -r label preset overrides <<<"$c"
    out="out/study/$name/$label"
    args=()
    for o in $overrides; do args+=(--set "$o"); done
    echo "study: $name $label" >&2
    "$bin" run "$s" --preset "$preset" "${args[@]}" --resolution 640x360 --no-images --no-progress --out "$out"
    dirs+=("$out")
  done
done
mkdir -p docs/studies
scripts/make_window_bars_study.py "${dirs[@]}" > docs/studies/window_bars.md.tmp
mv docs/studies/window_bars.md.tmp docs/studies/window_bars.md
echo "wrote docs/studies/window_bars.md" >&2
