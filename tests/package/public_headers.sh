#!/usr/bin/env bash
# Every public header compiles on its own, as the first and only include of a
# translation unit, as C11 (gcc, clang) and as C++11 and C++17 (g++,
# clang++), with -Wall -Wextra -pedantic -Werror. A compiler that is not
# installed is reported and skipped; at least one C and one C++ compiler
# must be there (with --c-only: a C compiler, for the core-only build).
#   public_headers.sh [--c-only] INCLUDE_DIR [EMBREE_INCLUDE_DIR]
set -euo pipefail
c_only=0
if [ "${1:-}" = --c-only ]; then c_only=1; shift; fi
inc=${1:?usage: public_headers.sh [--c-only] INCLUDE_DIR [EMBREE_INCLUDE_DIR]}
embree_inc=${2:-}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

combos=(
  "gcc -x c -std=c11"
  "clang -x c -std=c11"
  "g++ -x c++ -std=c++11"
  "g++ -x c++ -std=c++17"
  "clang++ -x c++ -std=c++11"
  "clang++ -x c++ -std=c++17"
)
# The core-only build's PATH has its C compiler as cc only.
[ $c_only = 1 ] && combos=("cc -x c -std=c11" "${combos[@]}")
have_c=0 have_cxx=0 fail=0 checked=0
for combo in "${combos[@]}"; do
  read -r cc x lang std <<<"$combo"
  if ! command -v "$cc" >/dev/null; then
    echo "skip: $cc not installed"
    continue
  fi
  case $std in *c++*) have_cxx=1 ;; *) have_c=1 ;; esac
  for h in "$inc"/spherecull.h "$inc"/spherecull/*.h; do
    name=${h#"$inc"/}
    src=$tmp/tu
    : >"$src"
    if [ "$name" = spherecull/sc_rtcray.h ]; then
      # Documented: Embree's ray header comes first.
      [ -n "$embree_inc" ] || continue
      echo '#include <embree3/rtcore_ray.h>' >>"$src"
    fi
    echo "#include <$name>" >>"$src"
    echo 'int sc_header_check_unit(void);' >>"$src"
    if ! "$cc" -x "$lang" "$std" -pedantic -Wall -Wextra -Werror -fsyntax-only -I"$inc" \
         ${embree_inc:+-I"$embree_inc"} "$src" 2>"$tmp/err"; then
      echo "FAIL: $name with $cc $std"
      sed 's/^/    /' "$tmp/err" | head -20
      fail=$((fail + 1))
    fi
    checked=$((checked + 1))
  done
done
[ $have_c = 1 ] || { echo "no C compiler found"; exit 1; }
[ $have_cxx = 1 ] || [ $c_only = 1 ] || { echo "no C++ compiler found"; exit 1; }
echo "$checked header compilations, $fail failed"
[ $fail = 0 ]
