#!/bin/sh
# Extracts the CGAL demo meshes (bunny00.off, armadillo.off, fandisk.off, ...)
# from the Debian package libcgal-demo into a cache outside the git tree,
# where scene files reach them as "cache:NAME" or "${SPHERECULL_MESHES}/NAME".
#
#   scripts/fetch-meshes.sh            # extract (no-op when already done)
#   scripts/fetch-meshes.sh --print    # print the cache directory only
#
# Cache: $SPHERECULL_MESHES, else ${XDG_CACHE_HOME:-$HOME/.cache}/spherecull/meshes
# (the same rule the scene loader uses). Meshes are never committed: they are
# large and carry their own licences (see /usr/share/doc/libcgal-dev/copyright).
set -eu

die() { echo "fetch-meshes: $*" >&2; exit 1; }

if [ -n "${SPHERECULL_MESHES:-}" ]; then
    cache=$SPHERECULL_MESHES
else
    base=${XDG_CACHE_HOME:-}
    if [ -z "$base" ]; then
        [ -n "${HOME:-}" ] || die "neither SPHERECULL_MESHES, XDG_CACHE_HOME nor HOME is set"
        base=$HOME/.cache
    fi
    cache=$base/spherecull/meshes
fi

if [ "${1:-}" = "--print" ]; then
    echo "$cache"
    exit 0
elif [ $# -gt 0 ]; then
    echo "usage: $0 [--print]" >&2
    exit 2
fi

# The tarball moved between Debian releases (libcgal-demo ships it under the
# libcgal-dev doc directory in bookworm), so ask dpkg rather than guess.
tarball=
if command -v dpkg >/dev/null 2>&1; then
    tarball=$(dpkg -L libcgal-demo 2>/dev/null | grep '/data\.tar\.gz$' | head -n 1 || true)
fi
if [ -z "$tarball" ]; then
    for t in /usr/share/doc/libcgal-dev/data.tar.gz /usr/share/doc/libcgal-demo/data.tar.gz; do
        [ -f "$t" ] && { tarball=$t; break; }
    done
fi
[ -n "$tarball" ] && [ -f "$tarball" ] ||
    die "libcgal-demo's data.tar.gz not found; install it with: sudo apt-get install libcgal-demo"

# Idempotent: the stamp records which tarball (size and mtime) filled the cache.
stamp_want=$(stat -c '%n %s %Y' "$tarball")
if [ -f "$cache/.stamp" ] && [ "$(cat "$cache/.stamp")" = "$stamp_want" ]; then
    echo "$cache (up to date)"
    exit 0
fi

mkdir -p "$cache" || die "cannot create $cache"
# Extract next to the cache and move files in, so an interrupted run never
# leaves a truncated mesh under its final name.
tmp=$(mktemp -d "$cache/.extract.XXXXXX") || die "cannot create a temporary directory in $cache"
trap 'rm -rf "$tmp"' EXIT INT TERM
tar -xzf "$tarball" -C "$tmp" --wildcards 'data/meshes/*' ||
    die "extracting data/meshes from $tarball failed"
[ -d "$tmp/data/meshes" ] || die "$tarball holds no data/meshes directory"
n=0
for f in "$tmp"/data/meshes/*; do
    [ -f "$f" ] || continue
    mv -f "$f" "$cache/" || die "cannot move $(basename "$f") into $cache"
    n=$((n + 1))
done
[ -f "$cache/bunny00.off" ] || die "bunny00.off missing from $tarball"
echo "$stamp_want" > "$cache/.stamp"
echo "$cache ($n meshes from $tarball)"
