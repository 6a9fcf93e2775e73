#!/usr/bin/env bash
# Keeps the test times ctest recorded in a build tree as the record a fresh tree starts from
# (tests/ctest_costs/PRESET.txt; CMakeLists.txt copies it into a build tree that has none, so that ctest -j starts
# the costliest tests first on CI's clean clone). Run after a whole `ctest --preset PRESET` on the 2-core machine.
# Usage: [BUILD_ROOT=DIR] scripts/refresh_test_costs.sh [release|asan ...]   (default: both; BUILD_ROOT: where the
# presets' build trees are, default the repository's build/)
set -euo pipefail
root=$(realpath "${BUILD_ROOT:-$(dirname "$0")/../build}")
cd "$(dirname "$0")/.."
presets=("$@")
(( ${#presets[@]} )) || presets=(release asan)
tmp=""
trap '[[ -n $tmp ]] && rm -f "$tmp"' EXIT
for p in "${presets[@]}"; do
  src=$root/$p/Testing/Temporary/CTestCostData.txt
  [[ -s $src ]] || { echo "refresh_test_costs.sh: $src: no recorded run (run ctest --preset $p first)" >&2; exit 2; }
  # Only the times (name, runs, seconds) of tests that ran: the list of last failures after '---' is that tree's,
  # not the record's. A name recorded with gtest's "  # GetParam() = ..." comment (a tree configured before
  # NO_PRETTY_VALUES) loses it, as the tests' names now do; ctest's own unreadable rewrite of such a line (its first
  # word, 0 runs) is dropped.
  tmp=$(mktemp tests/ctest_costs/.$p.XXXXXX)
  { sed '/^---$/,$d' "$src" |
      awk 'NF >= 3 && $(NF - 1) > 0 { cost = $NF; name = $0; sub(/ +#.*$/, "", name); sub(/ .*$/, "", name);
                                       printf "%s 1 %.3f\n", name, cost }' |
      LC_ALL=C sort -u -k1,1; echo ---; } > "$tmp"
  mv "$tmp" tests/ctest_costs/$p.txt
  tmp=""
  echo "tests/ctest_costs/$p.txt: $(grep -c ' ' tests/ctest_costs/$p.txt) tests, $(awk 'NF == 3 {s += $3} END {printf "%.0f", s}' tests/ctest_costs/$p.txt) s"
done
