#!/usr/bin/env bash
# Builds tests/consumer/components against the installed package (every
# optional library through find_package COMPONENTS) and runs it.
#   components.sh PREFIX WORK
set -euo pipefail
prefix=$1 work=$2
src=$(cd "$(dirname "$0")/../consumer/components" && pwd)
rm -rf "$work" && mkdir -p "$(dirname "$work")"
cmake -S "$src" -B "$work" -DCMAKE_PREFIX_PATH="$prefix" >"$work.log" 2>&1 || { cat "$work.log"; exit 1; }
cmake --build "$work" >>"$work.log" 2>&1 || { cat "$work.log"; exit 1; }
"$work/components" "$work/out.png"
test -s "$work/out.png"
