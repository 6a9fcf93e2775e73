#!/usr/bin/env bash
# Issue 39's ablation behind docs/studies/spmis_ablation.md: stochastic pairwise MIS (restir-spmis, seed 004) against
# standard pairwise spatial reuse (restir-unbiased) at EQUAL shifted candidates inside the revealed region (10 in
# the pixels whose temporal reuse failed: restir-unbiased's spatial.disocclusionNeighbours, restir-spmis's
# spatial.disocclusionDraws), over the stochastic pass's cell-search radius × canonical draws N_c × canonical pdf;
# run as one sweep (docs/sweep-format.md), then the generated document, whose line
# "best stochastic configuration: NAME (SETTINGS)" scripts/regime_study.sh takes as SPMIS_SET.
# Usage: [SEEDS=N] [RESOLUTION=WxH] [FRAMES=A:B] [OUT=DIR] [SLURM=1] scripts/spmis_ablation_study.sh [SEQUENCE.json ...]
#   defaults: 8 seeds (from each sequence's own), 640x360, each sequence's own frames, out/spmis-ablation;
#   sequences sliding_reveal and window_bars_pan. SLURM=1 runs the jobs as Slurm arrays through
#   scripts/slurm/submit.sh and waits for the merge (docs/cluster.md) instead of running them in this process.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BIN:-build/release/restir-sim}
seqs=("$@")
if [ ${#seqs[@]} -eq 0 ]; then
  seqs=(sequences/regimes/sliding_reveal.json sequences/window_bars_pan.json)
fi
out=${OUT:-out/spmis-ablation}
resolution=${RESOLUTION:-640x360}
mkdir -p "$out"
sequences=""
for s in "${seqs[@]}"; do sequences+="${sequences:+, }\"$(realpath "$s")\""; done
extra="\"resolution\": [${resolution%x*}, ${resolution#*x}], "
if [ -n "${FRAMES:-}" ]; then extra+="\"frames\": [${FRAMES%:*}, ${FRAMES#*:}], "; fi

# The configurations: the only list; comment a line out to trim the study. Listed alternating the methods where
# possible, since a sweep runs its jobs in this order (each configuration's seeds back to back) and the timings
# are taken job after job.
#   unbiased-k5x10   restir-unbiased as preset: 5 neighbours, 10 where temporal reuse failed (the revealed region)
#   unbiased-k10x10  restir-unbiased with neighbours = disocclusionNeighbours = 10 (the issue's baseline)
#   spmis-rR-ncC-P   restir-spmis, N = 5 draws, 10 where temporal reuse failed; cell-search start radius
#                    r1080 = 30/1080 image heights (the paper's 30 px at 1080p, 10 px at 360 rows) or
#                    r360 = 30/360 (the old 30 px at 360 rows); N_c = C canonical draws; P_c uniform or ∝ c_i
#   spmis-old        restir-spmis as the earlier studies measured it: no boost (5 draws everywhere), r360, N_c = 5,
#                    uniform P_c
spmis='"spatial.draws": 5, "spatial.disocclusionDraws": 10'
configs=(
  '{"name": "unbiased-k5x10", "preset": "restir-unbiased", "set": {"spatial.neighbours": 5, "spatial.disocclusionNeighbours": 10}}'
  '{"name": "spmis-r1080-nc5-uniform", "preset": "restir-spmis", "set": {'"$spmis"', "spatial.cellSearchRadius": 0.0277778, "spatial.canonicalDraws": 5, "spatial.canonicalPdf": "uniform"}}'
  '{"name": "unbiased-k10x10", "preset": "restir-unbiased", "set": {"spatial.neighbours": 10, "spatial.disocclusionNeighbours": 10}}'
  '{"name": "spmis-r1080-nc5-confidence", "preset": "restir-spmis", "set": {'"$spmis"', "spatial.cellSearchRadius": 0.0277778, "spatial.canonicalDraws": 5, "spatial.canonicalPdf": "confidence"}}'
  '{"name": "spmis-r1080-nc10-uniform", "preset": "restir-spmis", "set": {'"$spmis"', "spatial.cellSearchRadius": 0.0277778, "spatial.canonicalDraws": 10, "spatial.canonicalPdf": "uniform"}}'
  '{"name": "spmis-r1080-nc10-confidence", "preset": "restir-spmis", "set": {'"$spmis"', "spatial.cellSearchRadius": 0.0277778, "spatial.canonicalDraws": 10, "spatial.canonicalPdf": "confidence"}}'
  '{"name": "spmis-old", "preset": "restir-spmis", "set": {"spatial.draws": 5, "spatial.disocclusionDraws": 5, "spatial.cellSearchRadius": 0.0833333, "spatial.canonicalDraws": 5, "spatial.canonicalPdf": "uniform"}}'
  '{"name": "spmis-r360-nc5-uniform", "preset": "restir-spmis", "set": {'"$spmis"', "spatial.cellSearchRadius": 0.0833333, "spatial.canonicalDraws": 5, "spatial.canonicalPdf": "uniform"}}'
  '{"name": "spmis-r360-nc5-confidence", "preset": "restir-spmis", "set": {'"$spmis"', "spatial.cellSearchRadius": 0.0833333, "spatial.canonicalDraws": 5, "spatial.canonicalPdf": "confidence"}}'
  '{"name": "spmis-r360-nc10-uniform", "preset": "restir-spmis", "set": {'"$spmis"', "spatial.cellSearchRadius": 0.0833333, "spatial.canonicalDraws": 10, "spatial.canonicalPdf": "uniform"}}'
  '{"name": "spmis-r360-nc10-confidence", "preset": "restir-spmis", "set": {'"$spmis"', "spatial.cellSearchRadius": 0.0833333, "spatial.canonicalDraws": 10, "spatial.canonicalPdf": "confidence"}}'
)
list=""
for c in "${configs[@]}"; do list+="${list:+,
}    $c"; done
cat > "$out/spmis_ablation.json" <<JSON
{
  "sequences": [$sequences],
  $extra"seedCount": ${SEEDS:-8},
  "configs": [
$list
  ]
}
JSON
if [ "${SLURM:-0}" = 1 ]; then
  RESTIR_SIM=$bin RESTIR_SLURM_WAIT=1 scripts/slurm/submit.sh "$out/spmis_ablation.json" "$out"
else
  "$bin" sweep "$out/spmis_ablation.json" --out "$out"
fi
dirs=()
while read -r d; do dirs+=("$out/$d"); done < <("$bin" sweep "$out/spmis_ablation.json" --plan |
                                                sed 's/.*"dir":"\([^"]*\)".*/\1/')
mkdir -p docs/studies
scripts/make_spmis_ablation_study.py "${dirs[@]}" > docs/studies/spmis_ablation.md.tmp
mv docs/studies/spmis_ablation.md.tmp docs/studies/spmis_ablation.md
grep '^best stochastic configuration:' docs/studies/spmis_ablation.md >&2 || true
echo "wrote docs/studies/spmis_ablation.md (the sweep's own tables: $out/sweep.md); for the regime study:" \
     "SPMIS_SET=ablation scripts/regime_study.sh" >&2
