#!/usr/bin/env bash
# Bit-identity across machines (DESIGN §3, §9b) where the machine, not the SIMD target, picks the code: glibc's
# libm chooses its double-precision acos, exp, log, pow, sin and cos by CPU (an FMA variant where the CPU has FMA,
# the SSE2 baseline elsewhere), and the two differ in the last bit for a few inputs in ten thousand (measured:
# acos 1,145, exp 2,726, log 415, sin 2,941 of 4 M). The project calls some of them (Lambert's polygon formula in
# the reference's light distributions, the sky's row areas, texture decoding, FLIP's filters) where a changed
# last bit could reach an image. So a cluster whose nodes differ in FMA must still merge to a local run's bits:
# this runs the committed-hash tests, and whole runs of a sky scene, an asset scene and the flagship, with glibc
# forced to its baseline variants (GLIBC_TUNABLES), and compares them with this machine's own.
#
#   tests/cli/baseline_libm.sh RESTIR_SIM SIM_TESTS [WORKDIR]
set -euo pipefail
BIN=$(realpath "$1")
TESTS=$(realpath "$2")
cd "$(dirname "$0")/../.."
W=$(realpath -m "${3:-$(mktemp -d /tmp/restir-libm.XXXXXX)}")/baseline-libm
rm -rf "$W"
mkdir -p "$W"
BASELINE="glibc.cpu.hwcaps=-AVX2,-FMA,-FMA4,-AVX512F"

# The variants must really differ here, or this test proves nothing: exp, sin and log of 200,000 points through
# awk (Debian's mawk calls the same libm), with and without the tunable.
probe() {
  GLIBC_TUNABLES=$1 awk 'BEGIN { for (i = 0; i < 200000; i++) { x = (i * 0.6180339887498949) % 1.0
    printf "%.17g %.17g %.17g\n", exp(20 * x - 10), sin(10 * x), log(x + 1e-9) } }' | md5sum
}
own=$(probe "")
base=$(probe "$BASELINE")
if grep -qw fma /proc/cpuinfo; then
  if [ "$own" = "$base" ]; then
    echo "FAIL: this CPU has FMA but GLIBC_TUNABLES=$BASELINE did not change libm's exp, sin or log; the comparison would" \
         "prove nothing (has glibc renamed its hwcaps tunables?)" >&2
    exit 1
  fi
  echo "libm: FMA variant here, baseline variant forced for the comparison (exp, sin and log differ on this probe)"
else
  echo "libm: this CPU has no FMA, so its libm is the baseline variant already; the comparison is with itself"
fi

# The tests whose expected values are committed constants: the estimators' golden image hashes and the
# reference's bits (sky and asset configurations included).
GLIBC_TUNABLES=$BASELINE "$TESTS" --gtest_brief=1 \
  --gtest_filter='SimdDeterminism.ImageHashesEqualTheGoldenHashes:ReferenceBits.*'

# Whole runs, every preset, reference, FLIP and images, on each libm: metrics (timings aside), reference cache
# entries and EXR frames must be the same bytes.
run() {  # variant tunables sequence resolution frames
  GLIBC_TUNABLES=$2 "$BIN" run "$3" --preset all --resolution "$4" --frames "$5" --no-progress --no-report \
    --cache-dir "$W/$1/$(basename "$3" .json)/cache" --out "$W/$1/$(basename "$3" .json)/run" \
    >"$W/$1-$(basename "$3" .json).log" 2>&1 || { cat "$W/$1-$(basename "$3" .json).log" >&2; return 1; }
}
strip() {  # metrics.csv without its timing columns (ms_*)
  awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) keep[i] = $i !~ /^ms_/ }
           { line = ""; for (i = 1; i <= NF; i++) if (keep[i]) line = line "," $i; print line }' "$1"
}
files() { (cd "$1" && find . -name '*.exr' -o -name 'ref-*.bin' | sort | xargs md5sum); }
status=0
for case in "tests/data/sky_smoke.json 48x27 0:2" "sequences/asset_table.json 64x36 0:2" \
            "sequences/window_bars_pan.json 64x36 8:10"; do
  read -r seq res frames <<< "$case"
  run own "" "$seq" "$res" "$frames"
  run base "$BASELINE" "$seq" "$res" "$frames"
  name=$(basename "$seq" .json)
  if ! diff <(strip "$W/own/$name/run/metrics.csv") <(strip "$W/base/$name/run/metrics.csv") >/dev/null; then
    echo "FAIL: $name: metrics differ between libm variants" >&2
    status=1
  fi
  if ! diff <(files "$W/own/$name") <(files "$W/base/$name") >/dev/null; then
    echo "FAIL: $name: frames or reference differ between libm variants" >&2
    status=1
  fi
  [ $status = 0 ] && echo "$name: $(files "$W/own/$name" | wc -l) files and the metrics identical"
done
exit $status
