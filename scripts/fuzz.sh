#!/usr/bin/env bash
# Fuzzes the readers of untrusted files for a bounded time with libFuzzer + ASan + UBSan: the sequence parser
# (tests/fuzz/sequence_fuzz.cpp) for SECONDS, then the reference cache reader (cache_fuzz.cpp) and the metrics.csv
# reader of report and compare (metrics_csv_fuzz.cpp) for SECONDS/2 each, then the reader of a sweep job's
# relative-error frames (relative_error_fuzz.cpp) and the asset importer (asset_fuzz.cpp: glTF, GLB, OBJ and PLY
# through Assimp in its forked child, and the child's message to the parent) and the glTF checks alone, in process
# (gltf_fuzz.cpp) for SECONDS/4 each. Installs clang if
# missing, builds the `fuzz` preset (only the readers), seeds each from its shipped inputs, and fails on any
# finding (crash, uncaught exception, sanitizer report, timeout, leak, out-of-memory, a refusal that is not one line
# free of control bytes: tests/fuzz/fuzz_message.h), leaving the input that triggered it in
# build/fuzz/artifacts/<target>/.
# Usage: scripts/fuzz.sh [SECONDS]   (default 60; also FUZZ_SECONDS)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-${FUZZ_SECONDS:-60}}"

scripts/setup.sh --with-fuzz
cmake --preset fuzz
cmake --build --preset fuzz

# libFuzzer adds what it finds to the first directory and only reads the others; the work corpora live in the
# build tree, so the repository's files are never modified. libFuzzer reads seed directories recursively
# (sequences/ includes sequences/hard/).
export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:allocator_may_return_null=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"

# fuzz TARGET SECONDS MAX_LEN TIMEOUT SEEDS... [-- EXTRA LIBFUZZER FLAGS]
# TIMEOUT is libFuzzer's per-input limit in seconds: a hang is a finding.
fuzz() {
  local target=$1 secs=$2 maxlen=$3 timeout=$4
  shift 4
  local seeds=() extra=()
  while [ $# -gt 0 ] && [ "$1" != "--" ]; do seeds+=("$1"); shift; done
  [ $# -gt 0 ] && shift && extra=("$@")
  local work=build/fuzz/corpus/$target artifacts=build/fuzz/artifacts/$target
  mkdir -p "$work" "$artifacts"
  local status=0
  build/fuzz/"$target" "$work" "${seeds[@]}" "${extra[@]}" -max_total_time="$secs" -max_len="$maxlen" -timeout="$timeout" \
    -rss_limit_mb=2048 -malloc_limit_mb=1024 -artifact_prefix="$artifacts/" -print_final_stats=1 || status=$?
  if [ "$status" -ne 0 ]; then
    echo "fuzz: $target FAILED (exit $status); reproduce with: build/fuzz/$target $artifacts/<file>" >&2
    ls -l "$artifacts" >&2 || true
    exit "$status"
  fi
  echo "fuzz: $target: no findings in ${secs} s"
}

# The sequence parser imports every asset a sequence names, each in a forked importer and its textures in a forked
# decoder (sim/assets/asset_import.h): mutations of sequences/asset_table.json (five assets, eight forks) took up
# to 4 s per input under ASan on an idle 2-core machine, more as the fuzzer's memory grows (a fork copies its page
# tables) and under load, and 10 s once reported such a slow input as a hang (CI, stop 52, one child per texture). 30 s still reports a hang (of the importer's child too: its own limit is 60 s).
fuzz sequence_fuzz "$seconds" 8192 30 sequences tests/data/bad_sequences -- -dict=tests/fuzz/sequence.dict
fuzz cache_fuzz $(( (seconds + 1) / 2 )) 4096 10 tests/fuzz/cache_seeds
fuzz metrics_csv_fuzz $(( (seconds + 1) / 2 )) 8192 10 tests/fuzz/metrics_seeds
fuzz relative_error_fuzz $(( (seconds + 3) / 4 )) 256 10 tests/fuzz/relative_error_seeds
fuzz asset_fuzz $(( (seconds + 3) / 4 )) 16384 10 tests/fuzz/asset_seeds -- -dict=tests/fuzz/asset.dict
fuzz gltf_fuzz $(( (seconds + 3) / 4 )) 16384 10 tests/fuzz/gltf_seeds -- -dict=tests/fuzz/asset.dict
