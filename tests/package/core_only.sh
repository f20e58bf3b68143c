#!/usr/bin/env bash
# SPHERECULL_CORE_ONLY as on a machine with nothing but a C compiler: the
# configure, build and tests run on a PATH that holds only a C toolchain
# (cc, as, ld, ar, ranlib, readelf), make, cmake/ctest, a shell and
# coreutils; no pkg-config, no C++ compiler. Afterwards the cache must show
# that neither was looked for.
#   core_only.sh SRC_DIR WORK_DIR
set -euo pipefail
src=$1 work=$2
rm -rf "$work"
mkdir -p "$work/bin"
for t in cc as ld ld.bfd ar ranlib nm readelf make cmake ctest sh bash env \
         cat cp mv rm ls mkdir mktemp dirname basename sed grep head tail tr wc uname sort chmod awk diff; do
  p=$(command -v "$t") || { echo "core_only: $t not found"; exit 1; }
  ln -s "$p" "$work/bin/$t"
done
export PATH=$work/bin
export CC=cc
unset CXX PKG_CONFIG_PATH
cmake -S "$src" -B "$work/build" -DSPHERECULL_CORE_ONLY=ON -DSPHERECULL_WERROR=ON \
      -DCMAKE_BUILD_TYPE=Release >"$work/configure.log" 2>&1 || { cat "$work/configure.log"; exit 1; }
if grep -E '^(CMAKE_CXX_COMPILER|PKG_CONFIG_EXECUTABLE)[:=]' "$work/build/CMakeCache.txt" | grep -v NOTFOUND; then
  echo "core_only: the core-only configure looked for a C++ compiler or pkg-config"; exit 1
fi
cmake --build "$work/build" -j2 >"$work/build.log" 2>&1 || { tail -40 "$work/build.log"; exit 1; }
cd "$work/build"
ctest --output-on-failure
