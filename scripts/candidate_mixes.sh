#!/usr/bin/env bash
# Candidate mixes on the exterior flagship (issue 18): ris and restir-unbiased with different counts of local-light,
# sun, environment and BSDF candidates, 64 frames at 640x360 each, then docs/studies/candidate_mixes.md. The
# reference comes from (and goes to) the cache, so it is rendered once.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/release/restir-sim
mixes=(
  "l32:--set initial.candidates=32 --set initial.sunCandidates=0 --set initial.environmentCandidates=0"
  "l32s1e1:--set initial.candidates=32"
  "l32s1e1b1:--set initial.candidates=32 --set initial.brdfCandidates=1"
  "l8s1e1b1c:--set initial.candidates=8 --set initial.brdfCandidates=1 --set initial.brdfCutoff=0.0001"
  "l8s1e1:--set initial.candidates=8"
  "l16s2e4:--set initial.candidates=16 --set initial.sunCandidates=2 --set initial.environmentCandidates=4"
)
dirs=()
for m in "${mixes[@]}"; do
  name=${m%%:*}
  read -r -a args <<< "${m#*:}"
  "$bin" run sequences/sun_street_pan.json --preset ris,restir-unbiased "${args[@]}" --resolution 640x360 \
    --no-images --no-progress --no-report --out "out/mixes/sun_street_pan-$name"
  dirs+=("out/mixes/sun_street_pan-$name")
done
scripts/make_candidate_mixes.py "${dirs[@]}" > docs/studies/candidate_mixes.md.tmp
mv docs/studies/candidate_mixes.md.tmp docs/studies/candidate_mixes.md
echo "wrote docs/studies/candidate_mixes.md"
