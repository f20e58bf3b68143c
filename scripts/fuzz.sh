#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan) and runs each for
# SECONDS (default 30) on the kept corpus tests/fuzz/corpus/<name>.
#   ./scripts/fuzz.sh                         # every target, 30 s each (CI)
#   ./scripts/fuzz.sh 600 fuzz_circumsphere   # one target, longer
#   ./scripts/fuzz.sh --keep 3600             # the long run: 1 hour a target,
#                                             # then keep what it found
# New inputs go to build-fuzz/corpus/<name> (not into git). With --keep, the
# kept corpus and the new inputs are merged (libFuzzer -merge=1: the smallest
# set of inputs with the same coverage) into tests/fuzz/corpus/<name>, which
# ctest replays (test_fuzz_replay_<name>); commit it. Named files there
# (hand-written seeds, regress-* inputs) are always kept. A crash stops the run
# and leaves crash-* in build-fuzz/: fix it, then copy the input into
# tests/fuzz/corpus/<name>/ so the replay test keeps it as a regression.
set -euo pipefail
cd "$(dirname "$0")/.."
keep=0
if [ "${1:-}" = "--keep" ]; then
  keep=1
  shift
fi
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
# Inputs above 4 KiB find nothing the small ones do not and bloat the corpus.
opts=(-max_len=4096 -timeout=10 -rss_limit_mb=2048 -print_final_stats=1)
for t in "${targets[@]}"; do
  name=${t#fuzz_}
  kept="tests/fuzz/corpus/$name"
  mkdir -p "$dir/corpus/$name" "$kept"
  echo "fuzz: $t for ${seconds}s"
  (cd "$dir" && UBSAN_OPTIONS=halt_on_error=1 ./tests/fuzz/"$t" "${opts[@]}" -max_total_time="$seconds" \
     "corpus/$name" "../$kept" 2>&1 | grep -E '^(#[0-9]+ +DONE|stat::|==[0-9]+==ERROR|SUMMARY)' || true)
  if [ "$keep" = 1 ]; then
    merged="$dir/merged-$name"
    rm -rf "$merged"
    mkdir -p "$merged"
    (cd "$dir" && ./tests/fuzz/"$t" -merge=1 -max_len=4096 "merged-$name" "../$kept" "corpus/$name" \
       2>&1 | grep -E 'MERGE-OUTER: [0-9]+ new files' || true)
    # named inputs (seeds written by hand, regress-* crash inputs) stay
    # whatever their coverage; the merge names files by their hash
    find "$kept" -maxdepth 1 -type f ! -regex '.*/[0-9a-f]\{40\}' -exec cp {} "$merged"/ \;
    rm -rf "$kept.old"
    mv "$kept" "$kept.old" && mv "$merged" "$kept" && rm -rf "$kept.old"
    echo "kept: $kept $(ls "$kept" | wc -l) files, $(du -sh "$kept" | cut -f1)"
  fi
done
