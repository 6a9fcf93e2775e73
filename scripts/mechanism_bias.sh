#!/usr/bin/env bash
# Issue 20: what RTXDI's mechanisms (docs/architecture.md, "RTXDI's temporal and spatial mechanisms") do to bias,
# by the seed-ensemble split (run --ensemble, docs/metrics.md): each mechanism switched on against the same preset
# without it, on the flagship (a camera pan) and on moving_occluder (an occluder that moves: stale visibility).
# Writes docs/studies/rtxdi_mechanisms.md.
# Usage: [K=16] [RESOLUTION=320x180] [FRAMES=0:16] scripts/mechanism_bias.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-build/release/restir-sim}
out=${OUT:-out/mechanism-bias}
mkdir -p "$out"
common=(--frames "${FRAMES:-0:16}" --resolution "${RESOLUTION:-320x180}" --ensemble "${K:-16}" --no-images
        --no-progress --cache-dir "$out/cache")
# name, sequence, preset, settings...
runs=(
  "unbiased window_bars_pan restir-unbiased"
  "unbiased+boiling window_bars_pan restir-unbiased temporal.boilingFilterStrength=0.2"
  "unbiased+naive window_bars_pan restir-unbiased spatial.discountNaiveSamples=true"
  "unbiased+finalvis window_bars_pan restir-unbiased shade.reuseFinalVisibility=true"
  "rtxdi window_bars_pan rtxdi-defaults"
  "rtxdi-no-boiling window_bars_pan rtxdi-defaults temporal.boilingFilterStrength=0"
  "rtxdi-no-finalvis window_bars_pan rtxdi-defaults shade.reuseFinalVisibility=false"
  "unbiased moving_occluder restir-unbiased"
  "unbiased+finalvis moving_occluder restir-unbiased shade.reuseFinalVisibility=true"
  "rtxdi moving_occluder rtxdi-defaults"
  "rtxdi-no-finalvis moving_occluder rtxdi-defaults shade.reuseFinalVisibility=false"
  "unbiased+shortcut moving_occluder restir-unbiased temporal.visibilityShortcut=true shade.discardInvisibleSamples=true"
  "unbiased+fused window_bars_pan restir-unbiased temporal.fusedNeighbours=5 spatial.enabled=false"
)
dirs=()
for r in "${runs[@]}"; do
  read -r name seq preset sets <<<"$r"
  args=()
  for s in $sets; do args+=(--set "$s"); done
  dir="$out/$seq/$name"
  "$bin" run "sequences/$seq.json" "${common[@]}" --preset "$preset" "${args[@]}" --out "$dir"
  dirs+=("$dir")
done
mkdir -p docs/studies
scripts/make_mechanism_bias.py "${dirs[@]}" > docs/studies/rtxdi_mechanisms.md.tmp
mv docs/studies/rtxdi_mechanisms.md.tmp docs/studies/rtxdi_mechanisms.md
echo "wrote docs/studies/rtxdi_mechanisms.md" >&2
