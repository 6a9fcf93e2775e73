#!/usr/bin/env bash
# The cases of issue 14, run against a restir-sim binary as a user (or an attacker) would: damaged cache entries,
# full disks, coordinates and radiance past float range, inputs that would exhaust memory or block, a user's own
# files in --out, numbers that wrap, report and compare fed damaged runs. Each case states what must happen (exit
# 0 with the right result, or exit 2 with one clear message, nothing removed that the program did not create) and
# prints what did. Exit status 0 when every case holds.
#
#   tests/cli/hostile_cases.sh BINARY [WORKDIR]
#
# ctest runs it on the build's binary (tests/cli/CMakeLists.txt). Given an older binary it prints the "before"
# column of the issue's table. Needs: bash, coreutils, GNU time, mkfifo, oiiotool; mounts a small tmpfs for the
# full-disk cases when it may (root), and uses a file-size limit (ulimit -f) either way.
set -u
BIN=$(realpath "$1")
W=${2:-$(mktemp -d /tmp/restir-hostile.XXXXXX)}
mkdir -p "$W"
W=$(realpath "$W")
cd "$(dirname "$0")/../.."
FAILED=0
PASSED=0
TIMEOUT=60
# Under AddressSanitizer (the asan preset sets RESTIR_SANITIZED=ON) the shadow memory makes peak figures
# meaningless: the memory ceilings are not checked there, everything else is.
SANITIZED=no
case "${RESTIR_SANITIZED:-}" in ON|on|1|TRUE|true) SANITIZED=yes ;; esac
trap 'umount "$W/disk" 2>/dev/null' EXIT

# ---- helpers -------------------------------------------------------------------------------------------------

# sim ARGS...: the binary with a time limit; stdout+stderr in $W/log, peak memory (KiB) in $W/mem; returns its status
# (124: it hung, 128+N: signal N).
sim() {
  /usr/bin/time -f %M -o "$W/mem" timeout -k 5 "$TIMEOUT" "$BIN" "$@" >"$W/log" 2>&1
  local rc=$?
  # GNU time writes "Command terminated by signal N" / "Command exited with non-zero status N" before the figure.
  [ -s "$W/mem" ] || echo 0 >"$W/mem"
  return $rc
}
peak_mb() { echo $(( $(tail -n 1 "$W/mem") / 1024 )); }
lines() { grep -c '' "$W/log"; }
describe() {  # describe STATUS: "exit N", "hang", "SIGNAME"
  case "$1" in
    124|137) echo "hang (killed at ${TIMEOUT}s)" ;;
    13[0-9]|14[0-9]|15[0-9]) echo "signal $(kill -l $(( $1 - 128 )) 2>/dev/null || echo $(( $1 - 128 )))" ;;
    *) echo "exit $1" ;;
  esac
}
first_line() { head -n 1 "$W/log" | cut -c 1-110; }
# metrics.csv without the columns that differ between identical runs (timings, cache hits).
strip_timing() {
  awk -F, 'NR==1{for(i=1;i<=NF;i++) keep[i]=($i !~ /^ms_/ && $i != "reference_cached")}
           {s=""; for(i=1;i<=NF;i++) if(keep[i]) s=s $i ","; print s}' "$1"
}
# verdict ID DESCRIPTION EXPECTED GOT OK(0|1)
verdict() {
  if [ "$5" = 0 ]; then PASSED=$((PASSED + 1)); mark=ok; else FAILED=$((FAILED + 1)); mark=FAIL; fi
  printf '%-5s %-4s %-62s | want: %-36s | got: %s\n' "$1" "$mark" "$2" "$3" "$4"
}
# expect2 ID DESCRIPTION ARGS...: exit 2 with exactly one line.
expect2() {
  local id=$1 what=$2; shift 2
  sim "$@"; local rc=$?
  local ok=1; [ $rc = 2 ] && [ "$(lines)" = 1 ] && ok=0
  verdict "$id" "$what" "exit 2, one line" "$(describe $rc), $(lines) line(s): $(first_line)" $ok
}
SMALL=(--preset ris --resolution 32x18 --frames 0:3 --reference-spp 16 --no-progress)

# ---- 1. the reference cache ----------------------------------------------------------------------------------

C=$W/cache
rm -rf "$C" "$W/clean"
sim run sequences/smoke.json "${SMALL[@]}" --cache-dir "$C/entries" --out "$W/clean"
strip_timing "$W/clean/metrics.csv" >"$W/clean.csv"
ENTRIES=("$C"/entries/ref-*.bin)
if [ ! -f "${ENTRIES[0]}" ] || [ ${#ENTRIES[@]} -lt 2 ]; then
  echo "setup: the clean run wrote no cache entries" >&2
  exit 1
fi

# cache_case ID DESCRIPTION DAMAGE: damage the first entry with the shell command DAMAGE (on $E, another entry
# in $F), run again with the cache; the run must say so in one warning, and give the clean run's numbers.
cache_case() {
  local id=$1 what=$2 damage=$3
  rm -rf "$C/run" && cp -r "$C/entries" "$C/run"
  local E F
  E=$(ls "$C"/run/ref-*.bin | head -n 1)
  F=$(ls "$C"/run/ref-*.bin | tail -n 1)
  eval "$damage"
  sim run sequences/smoke.json "${SMALL[@]}" --cache-dir "$C/run" --out "$W/cached"
  local rc=$?
  local warned; warned=$(grep -c "warning" "$W/log")
  local same=no
  [ $rc = 0 ] && strip_timing "$W/cached/metrics.csv" | cmp -s - "$W/clean.csv" && same=yes
  local ok=1; [ $rc = 0 ] && [ "$same" = yes ] && [ "$warned" -ge 1 ] && ok=0
  verdict "$id" "$what" "exit 0, warning, clean numbers" "$(describe $rc), $warned warning(s), numbers equal: $same" $ok
}
cache_case 1.1 "16 bytes flipped in a cached reference" \
  'printf "\xde\xad\xbe\xef\xde\xad\xbe\xef\xde\xad\xbe\xef\xde\xad\xbe\xef" | dd of="$E" bs=1 seek=2000 conv=notrunc status=none'
cache_case 1.2 "a NaN written into a cached reference" \
  'printf "\x00\x00\xc0\x7f" | dd of="$E" bs=1 seek=1200 conv=notrunc status=none'
cache_case 1.3 "another frame's entry copied over one" 'cp "$F" "$E"'
cache_case 1.4 "an entry replaced by a FIFO" 'rm "$E" && mkfifo "$E"'
cache_case 1.5 "an entry cut in half" 'truncate -s $(( $(stat -c %s "$E") / 2 )) "$E"'
cache_case 1.6 "an entry replaced by a link to /dev/urandom" 'rm "$E" && ln -s /dev/urandom "$E"'
cache_case 1.7 "an entry with one byte appended" 'printf x >>"$E"'
cache_case 1.8 "an entry with its last byte (checksum) changed" \
  'printf "\x5a" | dd of="$E" bs=1 seek=$(( $(stat -c %s "$E") - 1 )) conv=notrunc status=none'

# ---- 2. full disks ----------------------------------------------------------------------------------------------

# After a failed write every file under OUT is whole: PNGs end in IEND, EXRs read to the last pixel, metrics.csv
# ends in a newline, and no temporary is left behind.
whole_outputs() {
  local out=$1 bad=""
  while IFS= read -r -d '' f; do
    case "$f" in
      *.png) tail -c 8 "$f" | grep -q IEND || bad="$bad ${f#$out/}" ;;
      *.exr) oiiotool "$f" --printstats >/dev/null 2>&1 || bad="$bad ${f#$out/}" ;;
      *.csv|*.json|*.html) [ ! -s "$f" ] || [ "$(tail -c 1 "$f" | od -An -c | tr -d ' ')" = '\n' ] || bad="$bad ${f#$out/}" ;;
    esac
  done < <(find "$out" -type f -print0 2>/dev/null)
  [ -d "$out/.restir-sim-tmp" ] && bad="$bad .restir-sim-tmp"
  echo "${bad:- }"
}
# full_disk_case ID DESCRIPTION LIMIT_KIB MODE(tmpfs|ulimit)
full_disk_case() {
  local id=$1 what=$2 kib=$3 mode=$4 out rc
  if [ "$mode" = tmpfs ]; then
    out=$W/disk/out
    sim run sequences/smoke.json --preset ris,restir-unbiased --reference-spp 16 --no-progress --cache-dir "" --out "$out"
    rc=$?
  else
    out=$W/fsize/out
    rm -rf "$W/fsize" && mkdir -p "$out"
    (ulimit -f "$kib"; trap '' XFSZ; sim run sequences/smoke.json --preset ris,restir-unbiased --reference-spp 16 \
       --no-progress --cache-dir "" --out "$out")
    rc=$?
  fi
  local msg; msg=$(first_line)
  local broken; broken=$(whole_outputs "$out")
  local ok=1
  [ $rc = 2 ] && [ "$(lines)" = 1 ] && [ "$broken" = " " ] && ! grep -q "restir-sim-tmp\|\.tmp[0-9]" "$W/log" &&
    grep -Eq "No space left on device|File too large" "$W/log" && ok=0
  verdict "$id" "$what" "exit 2 naming file+cause, all whole" \
    "$(describe $rc): $msg; broken:${broken}" $ok
}
MOUNTED=no
mkdir -p "$W/disk"
for kib in 160 260 420; do
  if mount -t tmpfs -o size=${kib}k tmpfs "$W/disk" 2>/dev/null; then
    MOUNTED=yes
    full_disk_case 2.$kib "full disk (tmpfs of ${kib} KiB)" "$kib" tmpfs
    umount "$W/disk"
  fi
done
[ $MOUNTED = yes ] || echo "2.x   skip (cannot mount a tmpfs here: not root?); the ulimit -f cases below stand in"
for kib in 4 24 60 100 200; do
  full_disk_case 2.f$kib "file-size limit (ulimit -f ${kib})" "$kib" ulimit
done

# ---- 3. numbers past float range --------------------------------------------------------------------------------

B=tests/data/bad_sequences
for f in camera_position_1e19 camera_lookat_1e38 light_center_1e20 light_radiance_overflow object_scaled_beyond_extent; do
  expect2 3.v "validate $f" validate "$B/$f.json"
  expect2 3.r "run $f" run "$B/$f.json" --frames 0:1 --no-progress --out "$W/far"
done
grep -q "zero-area" "$W/log" && verdict 3.3 "lights near 1e20 called zero-area" "no" "yes" 1
# A far but valid light: a 1.8e7 m quad. It runs, and every number it gives is finite.
sed 's/"u": \[0.25, 0, 0\], "v": \[0, 0, 0\]/"u": [9e6, 0, 0], "v": [0, 0, 9e6]/' "$B/light_zero_area.json" >"$W/far_light.json"
sim run "$W/far_light.json" --frames 0:2 --reference-spp 16 --no-progress --out "$W/far_light"
rc=$?
finite=no
[ $rc = 0 ] && ! grep -Eqi "nan|inf" "$W/far_light/metrics.csv" && finite=yes
verdict 3.6 "a valid light 1.8e7 m wide" "exit 0, finite metrics" "$(describe $rc), finite: $finite" \
  $([ $rc = 0 ] && [ $finite = yes ] && echo 0 || echo 1)

# ---- 4. memory and inputs that never end ------------------------------------------------------------------------

sed 's/"resolution": \[64, 36\]/"resolution": [16384, 16384]/; s/"frames": 6/"frames": 100000/' sequences/smoke.json \
  >"$W/huge.json"
# mem_case ID DESCRIPTION MAX_MB ARGS...: exit 2, one line, within MAX_MB of memory.
mem_case() {
  local id=$1 what=$2 max=$3; shift 3
  sim "$@"; local rc=$?
  local mb; mb=$(peak_mb)
  local ok=1; [ $rc = 2 ] && [ "$(lines)" = 1 ] && { [ "$mb" -le "$max" ] || [ $SANITIZED = yes ]; } && ok=0
  verdict "$id" "$what" "exit 2, one line, <= ${max} MB" "$(describe $rc), ${mb} MB: $(first_line)" $ok
}
mem_case 4.1 "16384^2 x 100000 frames" 400 run "$W/huge.json" --no-progress --out "$W/huge"
mem_case 4.2 "the same with --no-reference --frames 0:1" 400 run "$W/huge.json" --no-reference --frames 0:1 \
  --no-progress --out "$W/huge"
mem_case 4.3 "validate /dev/zero" 400 validate /dev/zero
mem_case 4.4 "run /dev/zero" 400 run /dev/zero --out "$W/zero"
mem_case 4.5 "run /dev/urandom" 400 run /dev/urandom --out "$W/urandom"
mkfifo "$W/fifo.json" 2>/dev/null
mem_case 4.6 "run a FIFO (nobody writing)" 400 run "$W/fifo.json" --out "$W/fifo"
mem_case 4.7 "validate a FIFO" 400 validate "$W/fifo.json"
{ printf '{"name": "k", "resolution": [8, 8], "frames": 100000, "materials": [{"name": "g", "type": "diffuse", "albedo": [0.5, 0.5, 0.5]}],\n'
  printf '"objects": [{"name": "o", "material": "g", "shape": {"type": "quad", "center": [0, 0, 0], "u": [0, 0, 1], "v": [1, 0, 0]}, "keyframes": [\n'
  awk 'BEGIN{for(i=0;i<1000000;i++) printf "{\"frame\": %d, \"translate\": [0, %d, 0]},\n", i % 100000, i}'
  printf '{"frame": 0}]}], "lights": [], "camera": {"keyframes": [{"frame": 0, "position": [0, 1, 3], "lookAt": [0, 0, 0]}]}}\n'
} >"$W/keys.json"
mem_case 4.8 "10^6 keyframes ($(( $(stat -c %s "$W/keys.json") >> 20 )) MiB)" 400 validate "$W/keys.json"
head -c $(( 15 << 20 )) "$W/keys.json" >"$W/keys15.json"
mem_case 4.9 "15 MiB of keyframes, cut (under the size cap)" 1500 validate "$W/keys15.json"
rm -rf "$W/mm"
sim run sequences/smoke.json --preset ris --frames 0:1 --max-memory 1M --no-progress --out "$W/mm"
rc=$?
ok=1; [ $rc = 2 ] && grep -q "needs about" "$W/log" && [ "$(lines)" = 1 ] && [ ! -e "$W/mm" ] && ok=0
verdict 4.10 "--max-memory 1M on the smoke test" "exit 2 naming the figure" "$(describe $rc): $(first_line)" $ok
sim run sequences/smoke.json --preset ris --frames 0:1 --resolution 32x18 --max-memory none --reference-spp 16 \
  --no-progress --out "$W/mm"
rc=$?
verdict 4.11 "--max-memory none" "exit 0" "$(describe $rc)" $([ $rc = 0 ] && echo 0 || echo 1)
mem_case 4.12 "sweep /dev/zero" 400 sweep /dev/zero --out "$W/sz"
mem_case 4.13 "sweep a FIFO" 400 sweep "$W/fifo.json" --out "$W/sz"

# ---- 5. a user's files in --out ---------------------------------------------------------------------------------

O=$W/thesis
rm -rf "$O" && mkdir -p "$O/frames/ris" "$O/deep/er"
for f in thesis.tmp2024.tex frames/ris/0000.tmp1.png deep/er/notes.tmp99 draft.tmp.12 .restir-sim-tmp-not-ours; do
  echo "mine" >"$O/$f"
done
sim run sequences/smoke.json "${SMALL[@]}" --cache-dir "" --out "$O"
rc=$?
kept=0
for f in thesis.tmp2024.tex frames/ris/0000.tmp1.png deep/er/notes.tmp99 draft.tmp.12 .restir-sim-tmp-not-ours; do
  [ "$(cat "$O/$f" 2>/dev/null)" = mine ] && kept=$((kept + 1))
done
verdict 5.1 "a user's *.tmp<digits>* files in --out" "exit 0, all 5 kept" "$(describe $rc), $kept of 5 kept" \
  $([ $rc = 0 ] && [ $kept = 5 ] && echo 0 || echo 1)
rm -rf "$W/shared"
for i in 1 2 3; do
  timeout -k 5 $TIMEOUT "$BIN" run sequences/smoke.json --preset ris,restir-unbiased --resolution 48x27 \
    --reference-spp 16 --no-progress --cache-dir "$W/shared/cache" --out "$W/shared" >"$W/shared$i.log" 2>&1 &
done
rcs=""
for job in $(jobs -p); do wait "$job"; rcs="$rcs $?"; done
sim report "$W/shared"
rc=$?
left=$(find "$W/shared" -name '.restir-sim-tmp' | wc -l)
verdict 5.2 "three runs at once sharing one --out and cache" "all exit 0, report reads it" \
  "exits:$rcs, report $(describe $rc), temporaries left: $left" \
  $([ "$rcs" = " 0 0 0" ] && [ $rc = 0 ] && [ "$left" = 0 ] && echo 0 || echo 1)
# A run killed mid-write leaves its temporaries; the next run in the same --out removes exactly those.
rm -rf "$W/killed"
"$BIN" run sequences/smoke.json --preset ris --resolution 256x144 --reference-spp 64 --no-progress --cache-dir "" \
  --out "$W/killed" >/dev/null 2>&1 &
sleep 1.5
kill -KILL $! 2>/dev/null
wait $! 2>/dev/null
echo "mine" >"$W/killed/keep.tmp1"
sim run sequences/smoke.json "${SMALL[@]}" --cache-dir "" --out "$W/killed"
rc=$?
left=$(find "$W/killed" -path '*.restir-sim-tmp*' | wc -l)
verdict 5.3 "after a killed run, the next run in its --out" "exit 0, stale area gone, file kept" \
  "$(describe $rc), $left stale, kept: $(cat "$W/killed/keep.tmp1" 2>/dev/null || echo no)" \
  $([ $rc = 0 ] && [ "$left" = 0 ] && [ "$(cat "$W/killed/keep.tmp1" 2>/dev/null)" = mine ] && echo 0 || echo 1)

# ---- 6. numbers on the command line ------------------------------------------------------------------------------

expect2 6.1 "--resolution 4294967328x18" run sequences/smoke.json --resolution 4294967328x18 --out "$W/cl"
expect2 6.2 "--frames 0:-1" run sequences/smoke.json --frames 0:-1 --out "$W/cl"
expect2 6.3 "--resolution 18x4294967328" run sequences/smoke.json --resolution 18x4294967328 --out "$W/cl"
expect2 6.4 "--resolution ' 32x18'" run sequences/smoke.json --resolution " 32x18" --out "$W/cl"
expect2 6.5 "--resolution 32x18x2" run sequences/smoke.json --resolution 32x18x2 --out "$W/cl"
expect2 6.6 "--frames -1:3" run sequences/smoke.json --frames -1:3 --out "$W/cl"
expect2 6.7 "--frames 2:2" run sequences/smoke.json --frames 2:2 --out "$W/cl"
expect2 6.8 "--frames 4294967296:" run sequences/smoke.json --frames 4294967296: --out "$W/cl"
expect2 6.9 "--threads 4294967297" run sequences/smoke.json --threads 4294967297 --out "$W/cl"
expect2 6.10 "--seed -1" run sequences/smoke.json --seed -1 --out "$W/cl"
expect2 6.11 "--reference-spp 1e9" run sequences/smoke.json --reference-spp 1e9 --out "$W/cl"
expect2 6.12 "--ensemble 0" run sequences/smoke.json --ensemble 0 --out "$W/cl"
expect2 6.13 "--max-memory -5G" run sequences/smoke.json --max-memory -5G --out "$W/cl"
expect2 6.19 "--exr-compression piz" run sequences/smoke.json --exr-compression piz --out "$W/cl"
printf '{"sequence": "%s/sequences/smoke.json", "resolution": [8, 8], "frames": [0, 1], "referenceSpp": 16, "presets": ["ris"]}\n' \
  "$PWD" >"$W/tiny_sweep.json"
expect2 6.14 "sweep --threads -3" sweep "$W/tiny_sweep.json" --threads -3 --out "$W/cl"
expect2 6.20 "--threads 1024" run sequences/smoke.json --threads 1024 --out "$W/cl"
expect2 6.21 "sweep --job ''" sweep "$W/tiny_sweep.json" --job "" --out "$W/cl"
expect2 6.22 "sweep --job 99" sweep "$W/tiny_sweep.json" --job 99 --out "$W/cl"
# 2^64 combinations: seven settings with 256 valid values each, two with 8 and one with 4; a product that wraps at
# 2^64 comes out as 0.
axis() { printf '"%s": [%s]' "$1" "$(seq -s, "$2" "$3" "$4")"; }
{ printf '{"sequence": "%s/sequences/smoke.json", "presets": ["ris"], "grid": {' "$PWD"
  axis temporal.maxHistory 1 1 256; printf ', '; axis initial.candidates 1 1 256; printf ', '
  axis spatial.radius 1 1 256; printf ', '; axis spatial.cellSearchRadius 0.001 0.001 0.256; printf ', '
  axis spatial.normalThreshold 0.5 0.001 0.755; printf ', '; axis spatial.depthThreshold 0.01 0.001 0.265
  printf ', '; axis spatial.cellSearchGrowth 1.1 0.001 1.355; printf ', '; axis spatial.neighbours 1 1 8
  printf ', '; axis spatial.draws 1 1 8; printf ', '; axis spatial.canonicalDraws 1 1 4; echo '}}'
} >"$W/grid.json"
sim sweep "$W/grid.json" --out "$W/sweep"
rc=$?
verdict 6.15 "a sweep grid of 2^64 combinations" "exit 2: more than 4096" "$(describe $rc): $(first_line)" \
  $([ $rc = 2 ] && grep -q 4096 "$W/log" && echo 0 || echo 1)
rm -rf "$W/dup"
sim run sequences/smoke.json --preset ris,ris --resolution 32x18 --frames 0:2 --no-progress --out "$W/dup"
rc=$?
verdict 6.16 "--preset ris,ris" "exit 2 up front, nothing written" \
  "$(describe $rc): $(first_line); out exists: $([ -e "$W/dup" ] && echo yes || echo no)" \
  $([ $rc = 2 ] && [ ! -e "$W/dup" ] && echo 0 || echo 1)
expect2 6.17 "--preset ris,restir-unbiased,ris" run sequences/smoke.json --preset ris,restir-unbiased,ris \
  --out "$W/dup"
R=$W/complete
rm -rf "$R"
sim run sequences/smoke.json "${SMALL[@]}" --cache-dir "" --out "$R"
before=$(cd "$R" && find . -type f -printf '%p %s %T@\n' | sort | md5sum)
sleep 1
sim run sequences/smoke.json "${SMALL[@]}" --cache-dir "" --out "$R" --resume
rc=$?
after=$(cd "$R" && find . -type f -printf '%p %s %T@\n' | sort | md5sum)
verdict 6.18 "--resume of a completed run" "exit 0, says complete, nothing touched" \
  "$(describe $rc): $(first_line); touched: $([ "$before" = "$after" ] && echo no || echo yes)" \
  $([ $rc = 0 ] && grep -q "complete" "$W/log" && [ "$before" = "$after" ] && echo 0 || echo 1)

# ---- 7. caches that cannot be written, report and compare fed damaged runs --------------------------------------

echo "a file" >"$W/plainfile"
sim run sequences/smoke.json "${SMALL[@]}" --cache-dir "$W/plainfile/cache" --out "$W/uc"
rc=$?
ok=1; [ $rc = 2 ] && [ "$(lines)" = 1 ] && grep -q "plainfile/cache" "$W/log" && ! grep -q "restir-sim-tmp" "$W/log" &&
  [ ! -e "$W/uc/metrics.csv" ] && ok=0
verdict 7.1 "--cache-dir under a regular file" "exit 2 before rendering, names it" "$(describe $rc): $(first_line)" $ok
expect2 7.2 "--cache-dir on a read-only file system (/proc)" run sequences/smoke.json "${SMALL[@]}" \
  --cache-dir /proc/restir-cache --out "$W/uc2"
expect2 7.3 "--out under a regular file" run sequences/smoke.json "${SMALL[@]}" --out "$W/plainfile/out"

# A complete run to damage.
G=$W/good
rm -rf "$G"
sim run sequences/smoke.json --preset ris,restir-unbiased --resolution 32x18 --frames 0:3 --reference-spp 16 \
  --no-progress --cache-dir "" --out "$G"
# damaged_run ID DESCRIPTION DAMAGE COMMAND: copy the good run, damage it (shell, $D is the copy), run COMMAND on it.
damaged_run() {
  local id=$1 what=$2 damage=$3 command=$4 D=$W/damaged
  rm -rf "$D" && cp -r "$G" "$D"
  eval "$damage"
  if [ "$command" = report ]; then sim report "$D"; else sim compare "$G" "$D"; fi
  local rc=$?
  local ok=1; [ $rc = 2 ] && [ "$(lines)" = 1 ] && ok=0
  verdict "$id" "$what" "exit 2, one line" "$(describe $rc), $(lines) line(s): $(first_line)" $ok
}
for cmd in report compare; do
  # Cut inside a column name ("ms_prima"), so every field the cut header has is a plausible name.
  damaged_run 7.4 "$cmd: metrics.csv cut inside its header" 'head -c 37 "$G/metrics.csv" >"$D/metrics.csv"' $cmd
  damaged_run 7.5 "$cmd: NUL bytes in a column name (relmse)" \
    'printf "\x00\x00" | dd of="$D/metrics.csv" bs=1 seek=$(( $(head -n 1 "$G/metrics.csv" | grep -bo ",relmse," | cut -d: -f1) + 3 )) conv=notrunc status=none' $cmd
  # Cut inside the last row's image_hash: the row keeps its field count.
  damaged_run 7.6 "$cmd: metrics.csv cut inside the last field" \
    'head -c $(( $(stat -c %s "$G/metrics.csv") - 5 )) "$G/metrics.csv" >"$D/metrics.csv"' $cmd
  damaged_run 7.7 "$cmd: a row with a field missing" 'sed -i "3s/,[^,]*$//" "$D/metrics.csv"' $cmd
  damaged_run 7.8 "$cmd: metrics.csv replaced by a FIFO" 'rm "$D/metrics.csv" && mkfifo "$D/metrics.csv"' $cmd
  damaged_run 7.9 "$cmd: header only" 'head -n 1 "$G/metrics.csv" >"$D/metrics.csv"' $cmd
done
damaged_run 7.10 "report: a preset named ../../escape" 'sed -i "2s/,ris,/,..\/..\/escape,/" "$D/metrics.csv"' report
damaged_run 7.11 "report: a truncated EXR" 'truncate -s 2000 "$D/frames/ris/0001.exr"' report
damaged_run 7.12 "report: a truncated PNG preview" 'truncate -s 300 "$D/frames/ris/0001.png"' report
damaged_run 7.13 "report: an EXR replaced by a FIFO" 'rm "$D/frames/ris/0002.exr" && mkfifo "$D/frames/ris/0002.exr"' report
damaged_run 7.14 "report: run.json replaced by /dev/zero" 'rm "$D/run.json" && ln -s /dev/zero "$D/run.json"' report
# Frames that are not the run's: another resolution, another sequence (the EXR's restir:sequenceHash); compare of
# runs of two sequences, and of rows outside run.json's frames.
sim run sequences/smoke.json --preset ris --resolution 48x27 --frames 0:3 --reference-spp 16 --no-progress \
  --cache-dir "" --out "$W/other_size"
sim run sequences/static_room.json --preset ris --resolution 32x18 --frames 0:3 --reference-spp 16 --no-progress \
  --cache-dir "" --out "$W/other_sequence"
damaged_run 7.16 "report: an EXR of another resolution" 'cp "$W/other_size/frames/ris/0001.exr" "$D/frames/ris/"' report
damaged_run 7.17 "report: an EXR of another sequence" \
  'cp "$W/other_sequence/frames/ris/0001.exr" "$D/frames/ris/"' report
damaged_run 7.18 "report: a preview of another size" 'cp "$W/other_size/frames/ris/0002.png" "$D/frames/ris/"' report
damaged_run 7.19 "compare: runs of two sequences" \
  'sed -i "s/\"contentHash\": \"[0-9a-f]*\"/\"contentHash\": \"0123456789abcdef\"/" "$D/run.json"' compare
damaged_run 7.20 "compare: a row past run.json's frames" 'sed -i "\$s/^2,/9,/" "$D/metrics.csv"' compare
# A finished run whose frame file was deleted: the resume writes it again (with its bits) instead of "complete".
D=$W/resumed
rm -rf "$D" && cp -r "$G" "$D" && rm "$D/frames/ris/0002.exr"
sim run sequences/smoke.json --preset ris,restir-unbiased --resolution 32x18 --frames 0:3 --reference-spp 16 \
  --no-progress --cache-dir "" --out "$D" --resume
rc=$?
ok=1; [ $rc = 0 ] && grep -q "0002.exr is missing" "$W/log" && cmp -s "$G/frames/ris/0002.exr" "$D/frames/ris/0002.exr" &&
  ok=0
verdict 7.21 "resume of a finished run whose EXR was deleted" "exit 0, names it, writes it again" \
  "$(describe $rc): $(first_line)" $ok

# Missing frames are not damage: the report leaves them out, and links nothing that is not there.
D=$W/missing
rm -rf "$D" && cp -r "$G" "$D" && rm "$D/frames/ris/0001.exr" "$D/frames/restir-unbiased/0001.png"
sim report "$D"
rc=$?
dangling=0
for src in $(grep -o 'src="[^"]*"' "$D/report.html" | sed 's/src="//; s/"$//' | grep -v '^data:'); do
  [ -f "$D/$src" ] || dangling=$((dangling + 1))
done
verdict 7.15 "report: an EXR and a PNG missing" "exit 0, no dangling links" "$(describe $rc), $dangling dangling" \
  $([ $rc = 0 ] && [ $dangling = 0 ] && echo 0 || echo 1)

# ---- 8. assets that break the glTF specification (issue 37) --------------------------------------------------

# Each is placed by a sequence and validated: exit 2 with one line that names what is wrong where ("says").
A=$W/assets
rm -rf "$A" && mkdir -p "$A"
BOX=/usr/share/assimp/models/glTF2/BoxTextured-glTF
cp "$BOX/BoxTextured.gltf" "$BOX/BoxTextured0.bin" "$BOX/CesiumLogoFlat.png" "$A/"
# asset_sequence FILE: a sequence in $A placing FILE (a name in $A) beside a floor under a quad light.
asset_sequence() {
  printf '{"name": "asset_probe", "resolution": [16, 9], "frames": 1,
  "materials": [{"name": "grey", "type": "diffuse", "albedo": [0.6, 0.6, 0.6]}],
  "objects": [{"name": "floor", "material": "grey", "shape": {"type": "quad", "center": [0, 0, 0], "u": [0, 0, 2], "v": [2, 0, 0]}},
              {"name": "thing", "asset": {"file": "%s"}}],
  "lights": [{"name": "key", "type": "quad", "center": [0, 3, 0], "u": [0.25, 0, 0], "v": [0, 0, 0.25], "color": [1, 1, 1], "intensity": 10}],
  "camera": {"keyframes": [{"frame": 0, "position": [0, 2, 5], "lookAt": [0, 0, 0]}]}}\n' "$1" >"$A/seq_$1.json"
  echo "$A/seq_$1.json"
}
# asset_case ID DESCRIPTION FILE SAYS: validate a sequence placing FILE; exit 2, one line, matching the regex SAYS.
asset_case() {
  sim validate "$(asset_sequence "$3")"; local rc=$?
  local ok=1; [ $rc = 2 ] && [ "$(lines)" = 1 ] && grep -qE "$4" "$W/log" && ok=0
  verdict "$1" "$2" "exit 2, one line: $4" "$(describe $rc), $(lines) line(s): $(cut -c 1-80 "$W/log" | head -n 1)" $ok
}
# gltf_variant NAME SED: BoxTextured.gltf edited by the sed script, reading its own copy of the buffer.
gltf_variant() {
  cp "$A/BoxTextured0.bin" "$A/$1.bin"
  sed -e "s/BoxTextured0.bin/$1.bin/" -e "$2" "$A/BoxTextured.gltf" >"$A/$1.gltf"
}
# poke FILE OFFSET HEXBYTES: overwrite bytes in place ("e803" writes 0xe8 0x03).
poke() { printf "$(echo "$3" | sed 's/../\\x&/g')" | dd of="$1" bs=1 seek="$2" conv=notrunc status=none; }

sim validate "$(asset_sequence BoxTextured.gltf)"
rc=$?
verdict 8.0 "glTF: the untouched textured box" "exit 0" "$(describe $rc)" $([ $rc = 0 ] && echo 0 || echo 1)
gltf_variant index1000 ''; poke "$A/index1000.bin" $((768 + 8)) e803
asset_case 8.1 "glTF: an index 1000 of 24 vertices" index1000.gltf 'primitives/0 index 4 .* is 1000, past its 24 vertices'
# A triangle with 32-bit indices, written whole: positions (0,0,0) (1,0,0) (0,0,1), indices 0 1 0xffffffff.
printf '\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x80\x3f\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x80\x3f\x00\x00\x00\x00\x01\x00\x00\x00\xff\xff\xff\xff' \
  >"$A/u32.bin"
printf '{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 0, 1]},
                {"bufferView": 1, "componentType": 5125, "count": 3, "type": "SCALAR"}],
  "bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 12}],
  "buffers": [{"uri": "u32.bin", "byteLength": 48}]}\n' >"$A/u32.gltf"
asset_case 8.2 "glTF: an index 0xffffffff" u32.gltf 'index 2 .* is 4294967295, past its 3 vertices'
gltf_variant scale '0,/"mesh": 0/s//"mesh": 0, "scale": ["nan", 1, 1]/'
asset_case 8.3 'glTF: a node scale ["nan", 1, 1]' scale.gltf '/nodes/1/scale/0 must be a number'
gltf_variant strength 's/"name": "Texture"/"name": "Texture", "emissiveFactor": [1, 1, 1], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": "50"}}/; s/"asset": {/"extensionsUsed": ["KHR_materials_emissive_strength"], "asset": {/'
asset_case 8.4 'glTF: emissiveStrength "50" (a string)' strength.gltf 'emissiveStrength must be a number'
gltf_variant factor5 's/"metallicFactor": 0.0/"metallicFactor": 0.0, "baseColorFactor": [5, 1, 1, 1]/'
asset_case 8.5 "glTF: baseColorFactor 5" factor5.gltf 'baseColorFactor/0 is 5, outside .*\[0.0, 1.0\]'
gltf_variant factor1e30 's/"metallicFactor": 0.0/"metallicFactor": 0.0, "baseColorFactor": [1, 1e30, 1, 1]/'
asset_case 8.6 "glTF: baseColorFactor 1e30" factor1e30.gltf 'baseColorFactor/1 is 1e\+30, outside'
# A sparse 1.5 GiB buffer file: refused from its size, never read (the peak stays small).
gltf_variant huge 's/"byteLength": 840/"byteLength": 1610612736/'
truncate -s 1536M "$A/huge.bin"
asset_case 8.7 "glTF: an external .bin of 1.5 GiB" huge.gltf 'buffers/0 .*larger than the 1 GiB'
[ "$SANITIZED" = yes ] || verdict 8.8 "... without reading it" "peak under 200 MB" "$(peak_mb) MB" \
  $([ "$(peak_mb)" -lt 200 ] && echo 0 || echo 1)
rm -f "$A/huge.bin"
GLB=/usr/share/assimp/models/glTF2/BoxTextured-glTF-Binary/BoxTextured.glb
size=$(stat -c %s "$GLB")
le32() { printf '%02x%02x%02x%02x' $(($1 & 255)) $(($1 >> 8 & 255)) $(($1 >> 16 & 255)) $(($1 >> 24 & 255)); }
cp "$GLB" "$A/total.glb"; poke "$A/total.glb" 8 "$(le32 $((size + 100)))"
asset_case 8.9 "GLB: its header's total length wrong" total.glb "gives its length as $((size + 100)) bytes but the file has $size"
json=$(od -An -tu4 -j12 -N4 "$GLB" | tr -d ' ')
head -c $((20 + json / 2)) "$GLB" >"$A/cut.glb"; poke "$A/cut.glb" 8 "$(le32 $((20 + json / 2)))"
asset_case 8.10 "GLB: its JSON chunk cut short" cut.glb "JSON chunk is $json bytes long and runs past the end"
cp "$GLB" "$A/past.glb"; poke "$A/past.glb" $((20 + json)) "$(le32 $size)"
asset_case 8.11 "GLB: its BIN chunk's length past the end" past.glb "chunk at byte $((20 + json)) is $size bytes long and runs past the end"

echo "hostile cases: $PASSED held, $FAILED failed"
[ $FAILED = 0 ]
