#!/bin/sh
# 'spherecull render' as a path tracer from the command line: the same PNG
# bytes for 1 and 2 threads and for two runs, the camera options equal to
# the scene file's camera, --tracer embree, usage errors as one line, and
# Ctrl-C leaving an existing output as it was; a scene of instances
# rendered through them.
#
#   tests/cli_render.sh path/to/spherecull path/to/scenes/cornell.json
set -u
S=${1:?usage: cli_render.sh SPHERECULL CORNELL_JSON}
C=${2:?usage: cli_render.sh SPHERECULL CORNELL_JSON}
dir=$(mktemp -d "${TMPDIR:-/tmp}/sc_cli_render.XXXXXX") || exit 1
trap 'rm -rf "$dir"' EXIT INT TERM
cd "$dir" || exit 1
fail=0
no() { echo "FAIL  $*"; fail=1; }
r() { "$S" render -q "$C" --width 64 --spp 2 "$@"; }

r --threads 1 -o t1.png || no "render --threads 1: exit status $?"
r --threads 2 -o t2.png || no "render --threads 2: exit status $?"
r --threads 2 -o t3.png || no "render (again): exit status $?"
cmp -s t1.png t2.png || no "1 and 2 threads give different PNG bytes"
cmp -s t2.png t3.png || no "two runs give different PNG bytes"
r --seed 7 -o seed.png && ! cmp -s t1.png seed.png || no "--seed changes nothing"

# The scene file's camera, given on the command line, is the same render.
r --eye 0.5,0.5,2.15 --target 0.5,0.5,0 --up 0,1,0 --fov 38 -o cam.png || no "camera options: exit status $?"
cmp -s t1.png cam.png || no "--eye/--target/--up/--fov equal to the file's camera give another image"
r --eye 0.2,0.6,1.8 -o moved.png && ! cmp -s t1.png moved.png || no "--eye does not move the camera"

if "$S" compare --help | grep -q 'embree'; then
  r --tracer embree -o e.png || no "render --tracer embree: exit status $?"
  [ -s e.png ] || no "render --tracer embree wrote no PNG"
fi

one_line() {
  "$S" render "$C" -o x.png "$@" > /dev/null 2> err.txt
  rc=$?
  [ "$rc" -eq 2 ] || no "render $*: exit status $rc, wanted 2"
  [ "$(wc -l < err.txt)" -eq 1 ] || no "render $*: $(wc -l < err.txt) lines on stderr"
  [ ! -e x.png ] || no "render $*: wrote x.png"
}
one_line --fov 0
one_line --fov 180
one_line --eye 1,2
one_line --eye 1,2,3,4
one_line --eye 1,2,x
one_line --spp 0
one_line --bounces 65
one_line --exposure inf
one_line --tracer nope
one_line --integrator path --debug normals
one_line --integrator paths
one_line --tracer embree --stats
one_line --eye 0.5,0.5,0 --target 0.5,0.5,0

# bench-render: one row per tracer, the CSV, and the watertight Embree's
# frame equal to ours away from edges.
"$S" bench-render -q 2>/dev/null; [ $? -eq 2 ] || no "bench-render -q (unknown option): exit status not 2"
if "$S" compare --help | grep -q 'embree'; then
  # The shipped scenes that need no download: no pixel away from edges may
  # differ between our frame and the watertight Embree's.
  "$S" bench-render "$C" "$(dirname "$C")/spheres.json" --width 64 --spp 2 --repeats 1 --threads 2 \
      --tracers spherecull,embree-robust --csv b.csv --images . > b.txt || no "bench-render: exit status $?"
  [ "$(wc -l < b.csv)" -eq 5 ] || no "bench-render CSV: $(wc -l < b.csv) lines, wanted 5"
  head -n 1 b.csv | grep -q '^scene,.*,differ_elsewhere,' || no "bench-render CSV header"
  awk -F, '$8 == "embree-robust" { n++; if ($18 != 0) bad = 1 } END { exit (n == 2 && !bad) ? 0 : 1 }' b.csv ||
    no "embree-robust's frame differs from ours away from edges: $(cat b.csv)"
  [ -s cornell_json-spherecull.png ] && [ -s cornell_json-embree-robust.png ] || no "bench-render --images wrote no frames"
fi
for bad in "--spp 0" "--tracers nope" "--threads 0" "--repeats 0"; do
  # shellcheck disable=SC2086
  "$S" bench-render "$C" $bad > /dev/null 2> err.txt
  rc=$?
  [ "$rc" -eq 2 ] || no "bench-render $bad: exit status $rc, wanted 2"
  [ "$(wc -l < err.txt)" -eq 1 ] || no "bench-render $bad: $(wc -l < err.txt) lines on stderr"
done

# A scene of instances renders through them, the same bytes on 1 and 2
# threads, and says so.
O="$(dirname "$C")/orchard.json"
"$S" render "$O" --width 96 --threads 1 -o o1.png > o1.txt || no "render orchard.json: exit status $?"
"$S" render -q "$O" --width 96 --threads 2 -o o2.png || no "render orchard.json --threads 2: exit status $?"
cmp -s o1.png o2.png || no "orchard.json: 1 and 2 threads give different PNG bytes"
grep -q "800 instances of 2 objects" o1.txt || no "orchard.json did not render through its instances: $(cat o1.txt)"

# Ctrl-C: exit status 130, the earlier file untouched, no temporary left.
echo "earlier" > keep.png
"$S" render -q "$C" --spp 4096 --threads 1 -o keep.png 2> int.txt &
pid=$!
sleep 1
kill -INT "$pid"
wait "$pid"
rc=$?
[ "$rc" -eq 130 ] || no "interrupted render: exit status $rc, wanted 130"
[ "$(cat keep.png)" = "earlier" ] || no "an interrupted render changed the earlier output"
[ "$(wc -l < int.txt)" -eq 1 ] || no "an interrupted render printed $(wc -l < int.txt) lines"
[ "$(ls -A | grep -c keep.png)" -eq 1 ] || no "an interrupted render left a temporary file: $(ls -A)"

[ "$fail" -eq 0 ] && echo "all render command checks passed"
exit "$fail"
