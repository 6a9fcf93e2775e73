#!/usr/bin/env bash
# Issue 41's study behind docs/studies/path_reuse.md: seed 004 in its own regime. Standard pairwise spatial reuse of
# ReSTIR GI's paths (restir-gi-unbiased, k neighbours) against stochastic pairwise MIS over cells (restir-gi-spmis,
# N draws), both over restir-unbiased's direct light (`--preset A+B`), so that the two differ in the GI spatial pass
# alone; on the sequences where indirect light matters, as one sweep (docs/sweep-format.md), then the generated
# document (scripts/make_regime_study.py --study path_reuse: the regime study's tables over the GI reservoirs).
# Usage: [SEEDS=N] [RESOLUTION=WxH] [FRAMES=A:B] [REFERENCE_SPP=N] [OUT=DIR] [SLURM=1]
#        scripts/path_reuse_study.sh [SEQUENCE.json ...]
#   defaults: 4 seeds, 320x180, frames 0:40, a 256-spp reference (the sequences' own cap, 48, leaves the path-traced
#   reference's noise above the estimators' post-reveal error).
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-build/release/restir-sim}
seqs=("$@")
# The two sunlit GI sequences (sparse contributions) and the lamp-lit flagship (dense), so the study spans a range.
if [ ${#seqs[@]} -eq 0 ]; then
  seqs=(sequences/shutter_reveal_sun.json sequences/window_bars_sun.json sequences/window_bars_pan.json)
fi
out=${OUT:-out/path-reuse-study}
mkdir -p "$out"
sequences=""
for s in "${seqs[@]}"; do sequences+="${sequences:+, }\"$(realpath "$s")\""; done
resolution=${RESOLUTION:-320x180}
frames=${FRAMES:-0:40}
# The two methods interleaved, so that their timings alternate; each gets about twice its neighbours or draws where
# temporal reuse failed, as in the regime study (3/6, 5/10, 8/15).
unbiased=restir-unbiased+restir-gi-unbiased
spmis=restir-unbiased+restir-gi-spmis
cat > "$out/path_reuse.json" <<JSON
{
  "sequences": [$sequences],
  "resolution": [${resolution%x*}, ${resolution#*x}],
  "frames": [${frames%:*}, ${frames#*:}],
  "referenceSpp": ${REFERENCE_SPP:-256},
  "seedCount": ${SEEDS:-4},
  "configs": [
    {"name": "unbiased-k3", "preset": "$unbiased",
     "set": {"indirect.spatial.neighbours": 3, "indirect.spatial.disocclusionNeighbours": 6}},
    {"name": "spmis-N2", "preset": "$spmis",
     "set": {"indirect.spatial.draws": 2, "indirect.spatial.disocclusionDraws": 4, "indirect.spatial.canonicalDraws": 2}},
    {"name": "unbiased-k5", "preset": "$unbiased",
     "set": {"indirect.spatial.neighbours": 5, "indirect.spatial.disocclusionNeighbours": 10}},
    {"name": "spmis-N3", "preset": "$spmis",
     "set": {"indirect.spatial.draws": 3, "indirect.spatial.disocclusionDraws": 6, "indirect.spatial.canonicalDraws": 3}},
    {"name": "unbiased-k8", "preset": "$unbiased",
     "set": {"indirect.spatial.neighbours": 8, "indirect.spatial.disocclusionNeighbours": 15}},
    {"name": "spmis-N5", "preset": "$spmis",
     "set": {"indirect.spatial.draws": 5, "indirect.spatial.disocclusionDraws": 10, "indirect.spatial.canonicalDraws": 5}},
    {"name": "spmis-N8", "preset": "$spmis",
     "set": {"indirect.spatial.draws": 8, "indirect.spatial.disocclusionDraws": 15, "indirect.spatial.canonicalDraws": 8}}
  ]
}
JSON
if [ "${SLURM:-0}" = 1 ]; then
  RESTIR_SIM=$bin RESTIR_SLURM_WAIT=1 scripts/slurm/submit.sh "$out/path_reuse.json" "$out"
else
  "$bin" sweep "$out/path_reuse.json" --out "$out"
fi
dirs=()
while read -r d; do dirs+=("$out/$d"); done < <("$bin" sweep "$out/path_reuse.json" --plan |
                                                sed 's/.*"dir":"\([^"]*\)".*/\1/')
mkdir -p docs/studies
scripts/make_regime_study.py --study path_reuse --svg docs/studies/path_reuse.svg "${dirs[@]}" \
  > docs/studies/path_reuse.md.tmp
mv docs/studies/path_reuse.md.tmp docs/studies/path_reuse.md
echo "wrote docs/studies/path_reuse.md and path_reuse.svg" >&2
