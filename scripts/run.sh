#!/usr/bin/env bash
# Set-up, build, and the main job: render the default scene to out/bunny.png,
# then trace the same scene with our tracer and with Embree and print the
# comparison (speed, disagreements with the exact oracle, prefilter work).
# Extra arguments go to `spherecull render`.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/fetch-meshes.sh
./scripts/build.sh
mkdir -p out
sc=./build/src/cli/spherecull
$sc render scenes/bunny.json -o out/bunny.png "$@"
echo "wrote out/bunny.png"
echo
$sc compare scenes/bunny.json \
    --tracers spherecull-off,spherecull-exact,spherecull-minimal,spherecull-p16,embree,embree-high,embree-robust,embree-p16,embree-p16-coherent,embree-p16-incoherent,embree-user-prefilter \
    --threads 1 --repeats 5 --oracle-rays 5000 --csv out/compare.csv
echo "wrote out/compare.csv"
