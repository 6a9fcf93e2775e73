#!/bin/bash
# Renders the configurations of tests/sim/reference/reference_bits_test.cpp with a given restir-sim binary and prints, per
# configuration, the size and the FNV-1a 64 of its reference cache entry's payload (mean, standard error,
# luminance standard error): the test's expected hashes. Usage: scripts/reference_bits_hashes.sh BINARY SCRATCH_DIR
set -eu
BIN=$(realpath "$1"); OUT=$(realpath -m "$2")
cd "$(dirname "$0")/.."
rm -rf "$OUT"; mkdir -p "$OUT"
cfg() { # name seq res frame spp-or-error [more run options]
  local extra="--reference-spp $5"; [[ $5 == e* ]] && extra="--reference-error ${5#e} --reference-cap 1048576"
  "$BIN" run "$2" --preset ris --resolution "$3" --frames "$4:$(($4+1))" $extra ${6:-} --no-images \
     --cache-dir "$OUT/$1/cache" --out "$OUT/$1/run" >/dev/null 2>&1 || echo "FAILED $1"
}
cfg flagship sequences/window_bars_pan.json 96x54 8 48
cfg flagship_error sequences/window_bars_pan.json 64x36 3 e0.05
cfg glossy_floor sequences/hard/glossy_floor.json 64x36 0 48
cfg sky_smoke tests/data/sky_smoke.json 48x27 1 64
cfg asset_table sequences/asset_table.json 64x36 0 32
cfg many_rooms sequences/regimes/many_rooms.json 48x27 0 16
cfg static_room sequences/static_room.json 64x36 0 64
cfg door_ajar sequences/regimes/door_ajar.json 48x27 0 32
cfg tile_lights tests/data/tile_lights.json 48x27 0 16
cfg sun_room_paths sequences/window_bars_sun.json 48x27 20 16 "--set indirect.bounces=1"
python3 - "$OUT" <<'PY'
import sys, os, struct, glob
def fnv(b, h=0xcbf29ce484222325):
    for x in b:
        h ^= x; h = (h * 0x100000001b3) & 0xffffffffffffffff
    return h
for d in sorted(os.listdir(sys.argv[1])):
    f = glob.glob(os.path.join(sys.argv[1], d, 'cache', 'ref-*.bin'))
    if len(f) != 1: print(d, 'entries', len(f)); continue
    b = open(f[0], 'rb').read()
    n = struct.unpack_from('<I', b, 8)[0]; p = 12 + n
    w, h = struct.unpack_from('<ii', b, p); p += 8
    p += 16  # the allocation: mean samples per pixel, scale (RSREF004)
    size = struct.unpack_from('<Q', b, p)[0]; p += 8
    print(d, w, h, '0x%016xull' % fnv(b[p:p+size]))
PY
