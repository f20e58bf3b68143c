#!/usr/bin/env bash
# Makes the Debian package with CPack and checks what it holds.
#   deb.sh BUILD_DIR
set -euo pipefail
build=$1
command -v dpkg-deb >/dev/null || { echo "no dpkg-deb: skipped"; exit 77; }
cd "$build"
rm -f spherecull_*.deb
cpack -G DEB >cpack.log 2>&1 || { cat cpack.log; exit 1; }
deb=$(ls spherecull_*.deb)
list=$(dpkg-deb -c "$deb")
for f in ./usr/include/spherecull.h ./usr/include/spherecull/sc_trace.h ./usr/bin/spherecull \
         spherecullConfig.cmake spherecullConfigVersion.cmake /pkgconfig/spherecull.pc \
         'libspherecull.so.[0-9.]*$' 'libspherecull.a$'; do
  grep -q -- "$f" <<<"$list" || { echo "$deb lacks $f"; exit 1; }
done
echo "$deb: $(grep -c . <<<"$list") entries; depends: $(dpkg-deb -f "$deb" Depends)"
