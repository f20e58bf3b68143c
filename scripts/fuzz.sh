#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan) and runs each for
# SECONDS (default 30) on its seed corpus under tests/fuzz/corpus/<name>.
#   ./scripts/fuzz.sh            # every target, 30 s each
#   ./scripts/fuzz.sh 600 fuzz_circumsphere   # one target, longer
# New inputs found go to build-fuzz/corpus/<name> (not into git); a crash
# leaves crash-* in build-fuzz/ — turn it into a regression test.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
seconds=${1:-30}
shift || true
dir=build-fuzz
CC=clang cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSPHERECULL_FUZZ=ON \
  -DSPHERECULL_TESTS=OFF -DSPHERECULL_SANITIZE=ON \
  -DCMAKE_C_FLAGS="-fsanitize=fuzzer-no-link" >/dev/null
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  mapfile -t targets < <(ls tests/fuzz/*.c | xargs -n1 basename | sed 's/\.c$//')
fi
cmake --build "$dir" -j"$(nproc)" --target "${targets[@]}" >/dev/null
for t in "${targets[@]}"; do
  name=${t#fuzz_}
  mkdir -p "$dir/corpus/$name" "tests/fuzz/corpus/$name"
  echo "fuzz: $t for ${seconds}s"
  (cd "$dir" && UBSAN_OPTIONS=halt_on_error=1 ./tests/fuzz/"$t" -max_total_time="$seconds" \
     -print_final_stats=1 "corpus/$name" "../tests/fuzz/corpus/$name" 2>&1 | tail -n 4)
done
