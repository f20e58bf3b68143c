#!/usr/bin/env bash
# Installs, from Debian, whatever spherecull needs that is missing.
# Idempotent and silent when everything is already there.
set -euo pipefail

packages=(
  build-essential cmake pkg-config     # compiler and build
  libmpfr-dev libgmp-dev               # high-precision reference (tests, accuracy report, oracle)
  libcmocka-dev                        # unit tests
  libembree-dev                        # the comparison tracer
  libassimp-dev                        # mesh loading
  libcjson-dev                         # scene files
  libpng-dev                           # image output
  libosmesa6-dev                       # offscreen raster reference
  gnuplot-nox                          # plots
  assimp-testmodels libcgal-demo       # shipped scenes take meshes from these
  clang libclang-rt-14-dev             # fuzzing (libFuzzer)
  valgrind                             # memcheck in CI
  libopenmpi-dev openmpi-bin           # mpirun -np N spherecull render (the MPI driver)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

if [ "$(id -u)" -ne 0 ]; then
  sudo=sudo
else
  sudo=
fi
echo "setup: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq >/dev/null
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
