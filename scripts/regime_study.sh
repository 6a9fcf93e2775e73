#!/usr/bin/env bash
# Issue 20's study behind docs/studies/regimes.md: standard pairwise reuse (restir-unbiased, k neighbours) against
# stochastic pairwise MIS (restir-spmis, N draws) on the regime sequences (sequences/regimes/: few pixels' samples
# reach the image) and, for the dense end, the flagship; run as one sweep (docs/sweep-format.md), then the
# generated document, which plots the equal-time change of the disoccluded region's error against the sequence's
# contributing fraction.
# Usage: [SEEDS=N] [RESOLUTION=WxH] [FRAMES=A:B] [SLURM=1] scripts/regime_study.sh [SEQUENCE.json ...]
#   defaults: 1 seed, each sequence's own resolution and frames; SLURM=1 runs the jobs as Slurm arrays
#   (scripts/slurm/submit.sh, docs/cluster.md).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-build/release/restir-sim}
seqs=("$@")
if [ ${#seqs[@]} -eq 0 ]; then
  seqs=(sequences/window_bars_pan.json sequences/regimes/door_ajar.json sequences/regimes/many_rooms.json
        sequences/regimes/sliding_reveal.json sequences/regimes/sun_street_night.json)
fi
out=${OUT:-out/regime-study}
mkdir -p "$out"
sequences=""
for s in "${seqs[@]}"; do sequences+="${sequences:+, }\"$(realpath "$s")\""; done
extra=""
if [ -n "${RESOLUTION:-}" ]; then extra+="\"resolution\": [${RESOLUTION%x*}, ${RESOLUTION#*x}], "; fi
if [ -n "${FRAMES:-}" ]; then extra+="\"frames\": [${FRAMES%:*}, ${FRAMES#*:}], "; fi
cat > "$out/regimes.json" <<JSON
{
  "sequences": [$sequences],
  $extra"seedCount": ${SEEDS:-1},
  "configs": [
    {"name": "unbiased-k3", "preset": "restir-unbiased",
     "set": {"spatial.neighbours": 3, "spatial.disocclusionNeighbours": 6}},
    {"name": "unbiased-k5", "preset": "restir-unbiased"},
    {"name": "unbiased-k8", "preset": "restir-unbiased",
     "set": {"spatial.neighbours": 8, "spatial.disocclusionNeighbours": 15}},
    {"name": "spmis-N2", "preset": "restir-spmis", "set": {"spatial.draws": 2, "spatial.canonicalDraws": 2}},
    {"name": "spmis-N3", "preset": "restir-spmis", "set": {"spatial.draws": 3, "spatial.canonicalDraws": 3}},
    {"name": "spmis-N5", "preset": "restir-spmis"},
    {"name": "spmis-N8", "preset": "restir-spmis", "set": {"spatial.draws": 8, "spatial.canonicalDraws": 8}}
  ]
}
JSON
if [ "${SLURM:-0}" = 1 ]; then
  RESTIR_SIM=$bin RESTIR_SLURM_WAIT=1 scripts/slurm/submit.sh "$out/regimes.json" "$out"
else
  "$bin" sweep "$out/regimes.json" --out "$out"
fi
dirs=()
while read -r d; do dirs+=("$out/$d"); done < <("$bin" sweep "$out/regimes.json" --plan |
                                                sed 's/.*"dir":"\([^"]*\)".*/\1/')
mkdir -p docs/studies
scripts/make_regime_study.py --svg docs/studies/regimes.svg "${dirs[@]}" > docs/studies/regimes.md.tmp
mv docs/studies/regimes.md.tmp docs/studies/regimes.md
echo "wrote docs/studies/regimes.md and regimes.svg" >&2
