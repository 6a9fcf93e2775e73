#!/usr/bin/env bash
# Installs the Debian 12 packages ReSTIR Sim builds against, only those not yet installed. Idempotent; uses sudo
# only when not root. Usage: scripts/setup.sh [--with-fuzz] [--with-slurm]
#   --with-fuzz   also Debian's clang and its compiler-rt (libFuzzer, ASan, UBSan) for the `fuzz` preset
#                 (scripts/fuzz.sh passes it; about 100 MB, so the plain setup leaves it out)
#   --with-slurm  also Slurm (slurmctld, slurmd, slurm-client) and munge, for the test that runs a sweep as a job
#                 array on a single-node cluster on localhost (tests/cli/slurm_sweep.sh; about 30 MB)
# The tools the tests read our EXRs with (exrheader, oiiotool) are always installed; --with-tools, which used to
# add them, is still accepted and does nothing.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libembree-dev          # Embree 3: rays
  libopenexr-dev         # OpenEXR 3: frames
  libopenimageio-dev     # OpenImageIO: previews, reading images
  libglm-dev             # GLM: math
  libhwy-dev             # Highway: SIMD with dynamic dispatch
  libtbb-dev             # oneTBB: parallel loops
  nlohmann-json3-dev     # sequence files, reports
  libcli11-dev           # command line
  libassimp-dev          # Assimp: glTF 2.0, OBJ/MTL and PLY assets
  assimp-testmodels      # third-party assets, good and malformed, that the importer's tests load
  libgtest-dev libgmock-dev libbenchmark-dev
  openexr openimageio-tools   # exrheader and oiiotool: the tests read our EXRs with the libraries' own tools
  chromium               # headless browser: a test renders report.html and checks its plots and images
  time                   # GNU time: the hostile-input cases measure each run's peak memory with it
)

for arg in "$@"; do
  case "$arg" in
    --with-fuzz) packages+=(clang libclang-rt-14-dev) ;;  # clang++ and libclang_rt.fuzzer/asan/ubsan
    --with-slurm) packages+=(slurmctld slurmd slurm-client munge) ;;  # the cluster test's Slurm
    --with-tools) ;;
    *) echo "setup: unknown option '$arg' (usage: scripts/setup.sh [--with-fuzz] [--with-slurm])" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
echo "setup: installing ${missing[*]}"
"${sudo_cmd[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done"
