#!/usr/bin/env bash
# Set-up, build, and the main job: render the default scene to out/bunny.png.
# Extra arguments go to `spherecull render`.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/fetch-meshes.sh
./scripts/build.sh
mkdir -p out
./build/src/cli/spherecull render scenes/bunny.json -o out/bunny.png "$@"
echo "wrote out/bunny.png"
