#!/usr/bin/env bash
# Builds and runs a consumer program (tests/consumer) against an installed
# spherecull, the way a user outside the tree would.
#   consume.sh install  BUILD_DIR PREFIX            cmake --install into PREFIX (fresh)
#   consume.sh cmake    PREFIX SRC_DIR WORK C|CXX shared|static
#   consume.sh pkgconfig PREFIX SRC_DIR WORK C|CXX
# Exit 77 (ctest: skipped) when the tool a mode needs is not installed.
set -euo pipefail
mode=${1:?mode}
case $mode in
install)
  build=$2 prefix=$3
  rm -rf "$prefix"
  cmake --install "$build" --prefix "$prefix" >/dev/null
  test -f "$prefix/include/spherecull.h"
  ls "$prefix"/lib*/cmake/spherecull/spherecullConfig.cmake >/dev/null
  echo "installed into $prefix"
  ;;
cmake)
  prefix=$2 src=$3 work=$4 lang=$5 kind=$6
  if [ "$lang" = CXX ] && ! command -v c++ >/dev/null; then echo "no C++ compiler: skipped"; exit 77; fi
  target=spherecull::spherecull
  [ "$kind" = static ] && target=spherecull::spherecull_static
  rm -rf "$work" && mkdir -p "$(dirname "$work")"
  cmake -S "$src" -B "$work" -DCMAKE_PREFIX_PATH="$prefix" -DSC_CONSUMER_LANG="$lang" \
        -DSC_CONSUMER_TARGET="$target" -DCMAKE_BUILD_TYPE=Release >"$work.log" 2>&1 ||
    { cat "$work.log"; exit 1; }
  cmake --build "$work" >>"$work.log" 2>&1 || { cat "$work.log"; exit 1; }
  if [ "$kind" = static ]; then
    # Linked statically: no libspherecull.so in the program's needs.
    if readelf -d "$work/consumer" | grep -q 'NEEDED.*libspherecull'; then
      echo "the static consumer needs libspherecull.so"; exit 1
    fi
  else
    readelf -d "$work/consumer" | grep -q 'NEEDED.*libspherecull\.so' ||
      { echo "the shared consumer does not load libspherecull.so"; exit 1; }
  fi
  "$work/consumer"
  ;;
pkgconfig)
  prefix=$2 src=$3 work=$4 lang=$5
  command -v pkg-config >/dev/null || { echo "no pkg-config: skipped"; exit 77; }
  if [ "$lang" = CXX ]; then
    command -v c++ >/dev/null || { echo "no C++ compiler: skipped"; exit 77; }
    cc=(c++ -std=c++17) file=consumer.cpp
  else
    cc=(cc -std=c11) file=consumer.c
  fi
  export PKG_CONFIG_PATH=$(dirname "$(ls -d "$prefix"/lib*/pkgconfig/spherecull.pc)")
  [ "$(pkg-config --modversion spherecull)" != "" ]
  rm -rf "$work" && mkdir -p "$work"
  libdir=$(pkg-config --variable=libdir spherecull)
  # shellcheck disable=SC2046
  "${cc[@]}" -Wall -Wextra -pedantic -Werror -o "$work/consumer" "$src/$file" \
    $(pkg-config --cflags --libs spherecull) -Wl,-rpath,"$libdir"
  "$work/consumer"
  ;;
*)
  echo "consume.sh: unknown mode $mode" >&2; exit 2 ;;
esac
