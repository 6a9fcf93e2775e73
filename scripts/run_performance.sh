#!/usr/bin/env bash
# Builds and runs the benchmarks behind docs/performance.md (bench/frame_bench.cpp, bench/kernels_bench.cpp),
# then regenerates the document from their JSON output. Takes about 10 minutes on the 2-core development machine.
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
  cmake --build "$build" --target frame_bench kernels_bench
else
  build=build/release
  [[ -f "$build/CMakeCache.txt" ]] || cmake --preset release
  cmake --build --preset release --target frame_bench kernels_bench
fi
out=${OUT_DIR:-$build/performance}
mkdir -p "$out"
"$build/kernels_bench" --benchmark_min_time=0.2 --benchmark_out_format=json --benchmark_out="$out/kernels_bench.json"
"$build/frame_bench" --benchmark_out_format=json --benchmark_out="$out/frame_bench.json"
scripts/make_performance.py "$out/frame_bench.json" "$out/kernels_bench.json" > docs/performance.md.tmp
mv docs/performance.md.tmp docs/performance.md
echo "wrote docs/performance.md (JSON in $out)"
