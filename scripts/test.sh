#!/usr/bin/env bash
# Set-up, build and the whole test suite. `--sanitize` builds and runs it
# under AddressSanitizer + UndefinedBehaviorSanitizer in build-sanitize/.
# `--tsan` builds only the tests labelled tsan (tests/test_threads.c) under
# ThreadSanitizer in build-tsan/ and runs them, in both MXCSR modes.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
./scripts/fetch-meshes.sh
if [ "${1:-}" = "--tsan" ]; then
  export SPHERECULL_BUILD_DIR=build-tsan
  cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSPHERECULL_TSAN=ON -DSPHERECULL_WERROR=ON \
        -DSPHERECULL_WITH_OSMESA=OFF >/dev/null
  cmake --build build-tsan -j"$(nproc)" --target test_threads >/dev/null
  export TSAN_OPTIONS=halt_on_error=1:second_deadlock_stack=1
  cd build-tsan
  exec ctest --output-on-failure -L tsan
elif [ "${1:-}" = "--sanitize" ]; then
  export SPHERECULL_BUILD_DIR=build-sanitize
  # Without the MPI driver: Open MPI's own allocations would fill LeakSanitizer's
  # report; mpi_render reports itself skipped here and runs in the plain build.
  ./scripts/build.sh -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSPHERECULL_SANITIZE=ON -DSPHERECULL_WERROR=ON \
                     -DSPHERECULL_MPI=OFF
  export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  export LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp:print_suppressions=0
else
  export SPHERECULL_BUILD_DIR=build
  ./scripts/build.sh -DSPHERECULL_WERROR=ON
fi
cd "$SPHERECULL_BUILD_DIR"
ctest --output-on-failure -j"$(nproc)"
