#!/usr/bin/env bash
# Set-up, build, and the main job: the circumsphere accuracy report.
# (The tracer work turns this into: render the default scene to PNG and
# print the Embree comparison.)
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/build.sh
mkdir -p out
./build/src/cli/spherecull accuracy --csv out/accuracy.csv "$@"
