#!/usr/bin/env bash
# scripts/check_layers.py fails on each kind of include it exists to stop, and passes the repository. Each case is a
# small tree of a few files (the script reads only what is there), with one fault; the script must exit 1 and name
# the line. Usage: tests/scripts/check_layers_test.sh REPO_ROOT
set -uo pipefail
root=$(cd "${1:-.}" && pwd)
check="python3 $root/scripts/check_layers.py"
scratch=$(mktemp -d); trap 'rm -rf "$scratch"' EXIT
failures=0

# case NAME EXPECTED_STATUS EXPECTED_TEXT FILE=CONTENT...
case_() {
  local name=$1 want=$2 text=$3; shift 3
  local dir="$scratch/$name"; mkdir -p "$dir"
  for spec in "$@"; do
    local file=${spec%%=*} content=${spec#*=}
    mkdir -p "$dir/$(dirname "$file")"; printf '%b\n' "$content" > "$dir/$file"
  done
  local out status
  out=$($check "$dir" 2>&1); status=$?
  if [[ $status -ne $want || ( -n $text && $out != *"$text"* ) ]]; then
    echo "FAIL $name: exit $status (want $want), output: $out"; failures=$((failures + 1))
  else
    echo "ok   $name"
  fi
}

case_ clean 0 "" 'core/a.h=#pragma once' 'sim/util/b.h=#include "core/a.h"' \
  'sim/scene/c.h=#include "sim/util/b.h"' 'sim/app/d.cpp=#include "sim/scene/c.h"'
case_ back_up 1 'sim/util/b.h:1: #include "sim/scene/c.h" -- layer util (rank 1) includes a higher layer' \
  'sim/util/b.h=#include "sim/scene/c.h"' 'sim/scene/c.h=#pragma once'
case_ peers 1 'includes a peer, reference' \
  'sim/estimator/p.cpp=#include "sim/reference/r.h"' 'sim/reference/r.h=#pragma once'
case_ core_to_sim 1 'layer core never includes sim/' 'core/a.h=#include "sim/util/b.h"' 'sim/util/b.h=#pragma once'
case_ core_embree 1 'layer core may not include embree' 'core/a.h=#include <embree3/rtcore.h>'
case_ assimp_in_scene 1 'layer scene may not include assimp/' 'sim/scene/a.cpp=#include <assimp/scene.h>'
case_ flat_file 1 'sim/x.cpp -- a file of sim/ belongs in the folder of its job' 'sim/x.cpp=int x;'
case_ loop 1 'loop of units: sim/scene/a <-> sim/scene/b' \
  'sim/scene/a.h=#include "sim/scene/b.h"' 'sim/scene/b.h=#include "sim/scene/a.h"'
case_ shadowing_test_header 1 'ambiguous' 'sim/scene/x.h=#pragma once' 'tests/sim/scene/x.h=#pragma once' \
  'tests/t.cpp=#include "sim/scene/x.h"'

# The repository itself holds to its layers.
if out=$($check "$root" 2>&1); then echo "ok   repository"; else echo "FAIL repository: $out"; failures=$((failures + 1)); fi
exit $((failures > 0))
