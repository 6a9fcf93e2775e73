#!/usr/bin/env bash
# Builds and runs the benchmarks behind docs/performance.md (bench/frame_bench.cpp, bench/kernels_bench.cpp),
# bench/reference_bench.cpp, bench/flip_bench.cpp and README command 1 (timed from an empty reference cache, into a
# temporary output and cache directory), then regenerates the document from their JSON output. Takes about 20
# minutes on the 2-core development machine; run it on an idle machine.
#
#   scripts/run_performance.sh                       release preset: cmake --build --preset release
#   BUILD_DIR=build/bench scripts/run_performance.sh  an already-configured build tree instead
#
# JSON goes to $OUT_DIR (default: $BUILD_DIR/performance). Frame benchmark knobs (see bench/frame_bench.cpp):
# RESTIR_BENCH_WIDTH/HEIGHT (1920x1080), RESTIR_BENCH_REPS (2), RESTIR_BENCH_FLOOR_REPS (2).
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ -n "${BUILD_DIR:-}" ]]; then
  build=$BUILD_DIR
  cmake --build "$build" --target frame_bench kernels_bench reference_bench flip_bench restir-sim
else
  build=build/release
  [[ -f "$build/CMakeCache.txt" ]] || cmake --preset release
  cmake --build --preset release --target frame_bench kernels_bench reference_bench flip_bench restir-sim
fi
out=${OUT_DIR:-$build/performance}
mkdir -p "$out"
"$build/kernels_bench" --benchmark_min_time=0.2 --benchmark_out_format=json --benchmark_out="$out/kernels_bench.json"
"$build/frame_bench" --benchmark_out_format=json --benchmark_out="$out/frame_bench.json"
"$build/reference_bench" --benchmark_out_format=json --benchmark_out="$out/reference_bench.json"
"$build/flip_bench" --benchmark_out_format=json --benchmark_out="$out/flip_bench.json"
# README command 1's run, from an empty cache (the build is done by now).
readme_dir=$(mktemp -d)
trap 'rm -rf "$readme_dir"' EXIT
readme_cmd="$build/restir-sim run sequences/window_bars_pan.json --preset all --out $readme_dir/out"
start=$(date +%s.%N)
$readme_cmd --cache-dir "$readme_dir/cache" --no-progress
end=$(date +%s.%N)
python3 - "$readme_dir/out/run.json" "$start" "$end" > "$out/readme_command.json" <<'PY'
import json, sys
run = json.load(open(sys.argv[1]))
print(json.dumps({"readme_command": "restir-sim run sequences/window_bars_pan.json --preset all --out out",
                  "wall_seconds": float(sys.argv[3]) - float(sys.argv[2]), "run": run}, indent=1))
PY
scripts/make_performance.py "$out/frame_bench.json" "$out/kernels_bench.json" "$out/reference_bench.json" \
  "$out/flip_bench.json" "$out/readme_command.json" > docs/performance.md.tmp
mv docs/performance.md.tmp docs/performance.md
echo "wrote docs/performance.md (JSON in $out)"
