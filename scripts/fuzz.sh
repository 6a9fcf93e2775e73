#!/usr/bin/env bash
# Fuzzes the sequence parser (tests/fuzz/sequence_fuzz.cpp) for a bounded time with libFuzzer + ASan + UBSan.
# Installs clang if missing, builds the `fuzz` preset (only the parser), seeds from the shipped sequences and
# the malformed corpus, and fails on any finding (crash, uncaught exception, sanitizer report, timeout, leak,
# out-of-memory), leaving the input that triggered it in build/fuzz/artifacts/.
# Usage: scripts/fuzz.sh [SECONDS]   (default 60; also FUZZ_SECONDS)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-${FUZZ_SECONDS:-60}}"

scripts/setup.sh --with-fuzz
cmake --preset fuzz
cmake --build --preset fuzz

# libFuzzer adds what it finds to the first directory and only reads the others; the work corpus lives in the
# build tree, so the repository's files are never modified. libFuzzer reads seed directories recursively
# (sequences/ includes sequences/hard/).
work=build/fuzz/corpus
artifacts=build/fuzz/artifacts
mkdir -p "$work" "$artifacts"

export ASAN_OPTIONS="${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:allocator_may_return_null=0}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"

status=0
build/fuzz/sequence_fuzz "$work" sequences tests/data/bad_sequences \
  -dict=tests/fuzz/sequence.dict -max_total_time="$seconds" -max_len=8192 -timeout=10 -rss_limit_mb=2048 \
  -malloc_limit_mb=1024 -artifact_prefix="$artifacts/" -print_final_stats=1 || status=$?
if [ "$status" -ne 0 ]; then
  echo "fuzz: FAILED (exit $status); reproduce with: build/fuzz/sequence_fuzz $artifacts/<file>" >&2
  ls -l "$artifacts" >&2 || true
  exit "$status"
fi
echo "fuzz: no findings in ${seconds} s"
