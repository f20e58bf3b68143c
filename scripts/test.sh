#!/usr/bin/env bash
# Set-up, build and the whole test suite. `--sanitize` builds and runs it
# under AddressSanitizer + UndefinedBehaviorSanitizer in build-sanitize/.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/fetch-meshes.sh
if [ "${1:-}" = "--sanitize" ]; then
  export SPHERECULL_BUILD_DIR=build-sanitize
  ./scripts/build.sh -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSPHERECULL_SANITIZE=ON -DSPHERECULL_WERROR=ON
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  export LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp:print_suppressions=0
else
  export SPHERECULL_BUILD_DIR=build
  ./scripts/build.sh -DSPHERECULL_WERROR=ON
fi
cd "$SPHERECULL_BUILD_DIR"
ctest --output-on-failure -j"$(nproc)"
