#!/usr/bin/env bash
# Issue 20's study behind docs/studies/regimes.md: standard pairwise reuse (restir-unbiased, k neighbours) against
# stochastic pairwise MIS (restir-spmis, N draws) on the regime sequences (sequences/regimes/: few pixels' samples
# reach the image) and, for the dense end, the flagship; run as one sweep (docs/sweep-format.md), then the
# generated document, which plots the equal-time change of the disoccluded region's error against the sequence's
# contributing fraction.
# Usage: [SEEDS=N] [RESOLUTION=WxH] [FRAMES=A:B] [OUT=DIR] [SPMIS_SET=SETTINGS|ablation] [SLURM=1]
#        scripts/regime_study.sh [SEQUENCE.json ...]
#   defaults: 1 seed, each sequence's own resolution and frames; SLURM=1 runs the jobs as Slurm arrays
#   (scripts/slurm/submit.sh, docs/cluster.md). SPMIS_SET: settings added to every restir-spmis configuration
#   (overriding the ones it names), as a JSON object fragment, e.g.
#   SPMIS_SET='"spatial.canonicalPdf": "confidence", "spatial.cellSearchRadius": 0.0277778'; "ablation" takes them
#   from the line "best stochastic configuration: NAME (SETTINGS)" of docs/studies/spmis_ablation.md
#   (scripts/spmis_ablation_study.sh); empty: the preset's defaults.
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
spmisSet=${SPMIS_SET:-}
if [ "$spmisSet" = ablation ]; then
  spmisSet=$(sed -n 's/^best stochastic configuration: [^ ]* (\(.*\))$/\1/p' docs/studies/spmis_ablation.md | head -n 1)
  if [ -z "$spmisSet" ]; then
    echo "regime_study: no 'best stochastic configuration' line in docs/studies/spmis_ablation.md" >&2
    exit 2
  fi
  echo "regime_study: restir-spmis with $spmisSet (docs/studies/spmis_ablation.md)" >&2
fi
# The two methods interleaved (a sweep runs its jobs in this order, so the timings alternate between them). Each
# stochastic configuration gets about twice its draws where temporal reuse failed (spatial.disocclusionDraws), as
# the standard reuse gets about twice its neighbours there (spatial.disocclusionNeighbours): 3/6, 5/10, 8/15.
cat > "$out/regimes.json" <<JSON
{
  "sequences": [$sequences],
  $extra"seedCount": ${SEEDS:-1},
  "configs": [
    {"name": "unbiased-k3", "preset": "restir-unbiased",
     "set": {"spatial.neighbours": 3, "spatial.disocclusionNeighbours": 6}},
    {"name": "spmis-N2", "preset": "restir-spmis",
     "set": {"spatial.draws": 2, "spatial.disocclusionDraws": 4, "spatial.canonicalDraws": 2}},
    {"name": "unbiased-k5", "preset": "restir-unbiased",
     "set": {"spatial.neighbours": 5, "spatial.disocclusionNeighbours": 10}},
    {"name": "spmis-N3", "preset": "restir-spmis",
     "set": {"spatial.draws": 3, "spatial.disocclusionDraws": 6, "spatial.canonicalDraws": 3}},
    {"name": "unbiased-k8", "preset": "restir-unbiased",
     "set": {"spatial.neighbours": 8, "spatial.disocclusionNeighbours": 15}},
    {"name": "spmis-N5", "preset": "restir-spmis",
     "set": {"spatial.draws": 5, "spatial.disocclusionDraws": 10, "spatial.canonicalDraws": 5}},
    {"name": "spmis-N8", "preset": "restir-spmis",
     "set": {"spatial.draws": 8, "spatial.disocclusionDraws": 15, "spatial.canonicalDraws": 8}}
  ]
}
JSON
if [ -n "$spmisSet" ]; then
  python3 - "$out/regimes.json" "$spmisSet" <<'PY'
import json, sys
path, extra = sys.argv[1], json.loads("{" + sys.argv[2] + "}")
with open(path) as f:
    spec = json.load(f)
for c in spec["configs"]:
    if c["preset"] == "restir-spmis":
        c.setdefault("set", {}).update(extra)
with open(path, "w") as f:
    json.dump(spec, f, indent=2)
    f.write("\n")
PY
fi
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
