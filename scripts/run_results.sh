#!/usr/bin/env bash
# Runs the results of docs/results.md: window_bars_pan, sun_street_pan, static_room and asset_table at 640x360, every frame,
# every preset of the ReSTIR pipeline, plus ris and temporal with history counted in candidates (seed 003's
# representedM), then regenerates the document. References come from (and go to) the reference cache.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/release/restir-sim
presets=ris,temporal,restir-biased,restir-vis,restir-wisvis,restir-unbiased,restir-balance,restir-spmis
# rtxdi-defaults (issue 18) runs on the exterior flagship, whose sky its candidate mix is for.
extra() { [ "$1" = sun_street_pan ] && echo ",rtxdi-defaults"; }
dirs=()
for s in window_bars_pan sun_street_pan static_room asset_table; do
  "$bin" run "sequences/$s.json" --preset "$presets$(extra "$s")" --resolution 640x360 --no-images --no-progress \
    --out "out/results/$s"
  "$bin" run "sequences/$s.json" --preset ris,temporal --set initial.countCandidates=true --resolution 640x360 \
    --no-images --no-progress --out "out/results/$s-seed003"
  dirs+=("out/results/$s" "out/results/$s-seed003")
done
scripts/make_results.py "${dirs[@]}" > docs/results.md.tmp
mv docs/results.md.tmp docs/results.md
echo "wrote docs/results.md"
