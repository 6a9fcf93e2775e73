#!/usr/bin/env bash
# Installs the Debian 12 packages ReSTIR Sim builds against, only those not yet installed. Idempotent; uses sudo
# only when not root. Usage: scripts/setup.sh [--with-fuzz] [--with-slurm]
#   --with-fuzz   also Debian's clang and its compiler-rt (libFuzzer, ASan, UBSan) for the `fuzz` preset
#                 (scripts/fuzz.sh passes it; about 100 MB, so the plain setup leaves it out)
#   --with-slurm  also Slurm (slurmctld, slurmd, slurm-client) and munge, for the test that runs a sweep as a job
#                 array on a single-node cluster on localhost (tests/cli/slurm_sweep.sh; about 30 MB)
#   --with-gltf-validator
#                 also the Khronos glTF validator (npm's gltf-validator, the version tests/tools/gltf_validator's
#                 package-lock.json pins, 110 KB, no dependencies) under tests/tools/gltf_validator/node_modules, with
#                 Debian's nodejs and npm where the machine has no node or npm: the importer's oracle test
#                 (tests/sim/assets/gltf_validator_oracle_test.cpp) runs it. This one step uses the npm registry.
# The tools the tests read our EXRs with (exrheader, oiiotool) are always installed; --with-tools, which used to
# add them, is still accepted and does nothing.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libembree-dev          # Embree 3: rays
  libopenexr-dev         # OpenEXR 3: frames
  libopenimageio-dev     # OpenImageIO: previews, reading images
  libpng-dev             # libpng: the scrubber's palette and grey PNGs (OpenImageIO's writer makes RGB only)
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
  firefox-esr            # the second browser the report's scrubber is tested in (Chromium's and Firefox's engines)
  ffmpeg                 # the run's videos (sim/output/video.h); its ffprobe checks them in the tests
  time                   # GNU time: the hostile-input cases measure each run's peak memory with it
)

validator=no
for arg in "$@"; do
  case "$arg" in
    --with-gltf-validator)
      validator=yes
      # Only where missing: a machine's own Node.js (NodeSource's, say) ships npm and conflicts with Debian's npm.
      command -v node >/dev/null || packages+=(nodejs)
      command -v npm >/dev/null || packages+=(npm) ;;
    --with-fuzz) packages+=(clang libclang-rt-14-dev) ;;  # clang++ and libclang_rt.fuzzer/asan/ubsan
    --with-slurm) packages+=(slurmctld slurmd slurm-client munge) ;;  # the cluster test's Slurm
    --with-tools) ;;
    *) echo "setup: unknown option '$arg' (usage: scripts/setup.sh [--with-fuzz] [--with-slurm]" \
            "[--with-gltf-validator])" >&2; exit 2 ;;
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
else
  sudo_cmd=()
  if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
  echo "setup: installing ${missing[*]}"
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" \
    >/dev/null
  echo "setup: done"
fi

# The glTF validator at the version the lock file pins (npm ci checks the package's integrity hash against it).
if [ "$validator" = yes ]; then
  dir="$(dirname "$0")/../tests/tools/gltf_validator"
  want=$(sed -n 's/.*"gltf-validator": "\(.*\)".*/\1/p' "$dir/package.json")
  have=$(sed -n 's/^ *"version": "\(.*\)".*/\1/p' "$dir/node_modules/gltf-validator/package.json" 2>/dev/null || true)
  if [ "$have" = "$want" ]; then
    echo "setup: gltf-validator $want present"
  else
    echo "setup: installing gltf-validator $want (npm)"
    (cd "$dir" && npm ci --no-audit --no-fund --loglevel=error >/dev/null)
    echo "setup: gltf-validator $want installed"
  fi
fi
