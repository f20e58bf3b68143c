#!/bin/sh
# Bad input at the command line: every case must exit non-zero
# with exactly one line on stderr ("spherecull: ..."), and leave the output
# directory as it was: no new file (no partial output, no temporary), no
# changed file.
#
#   tests/cli_bad_input.sh path/to/spherecull [tests/data]
#
# Cases the CLI does not meet yet are marked xfail with the reason; if one
# starts passing the run fails (XPASS) so the mark gets removed.
set -u
S=${1:?usage: cli_bad_input.sh SPHERECULL [DATA_DIR]}
DATA=${2:-$(dirname "$0")/data}
MODELS=/usr/share/assimp/models
case $S in /*) ;; *) S=$(cd "$(dirname "$S")" && pwd)/$(basename "$S") ;; esac

root=$(mktemp -d "${TMPDIR:-/tmp}/sc_cli_bad.XXXXXX") || exit 1
trap 'chmod -R u+w "$root" 2>/dev/null; rm -rf "$root"' EXIT INT TERM
work=$root/work
mkdir -p "$work" "$root/in" "$root/ro"
: > "$root/in/empty.obj"
printf '{ "meshes": [ {"file": "proc:sphere:100"} ' > "$root/in/syntax.json"
printf '{ "meshes": [ {"file": "no_such.obj"} ] }' > "$root/in/missing_ref.json"
printf '{ "meshes": [ {"file": "proc:sphere:100"} ], "width": 1e9, "height": 1e9 }' > "$root/in/huge.json"
printf 'v 0 0 0\nv 1 0 0\nf 1 2 3\n' > "$root/in/bad_index.obj"
head -c 4096 /dev/urandom > "$root/in/noise.stl"
# Files that crash or hang assimp in-process (tests/test_scene_bad.c).
[ -r $MODELS/COB/molecule.cob ] && head -c 909 $MODELS/COB/molecule.cob > "$root/in/cut.cob"
if [ -r $MODELS/X/fromtruespace_bin32.x ]; then
  cp $MODELS/X/fromtruespace_bin32.x "$root/in/segv.x"
  printf '\275' | dd of="$root/in/segv.x" bs=1 seek=298575 conv=notrunc 2>/dev/null
fi
# An output path whose directory refuses new files. root ignores mode
# bits, so there /proc stands in for a read-only directory.
chmod 555 "$root/ro"
if [ "$(id -u)" = 0 ]; then ro=/proc; else ro=$root/ro; fi
# A symlink to a device: writing through it must fail (ENOSPC) or be
# refused; it must never be replaced by a file.
ln -s /dev/full "$root/full"

pass=0 fail=0 xfail=0
SMALL_R="--width 24 --height 16"
SMALL_C="--repeats 1 --count 64 --oracle-rays 8 --width 16 --rays primary --tracers spherecull-off --threads 1"
SMALL_B="--repeats 1 --size 16x12 --threads 1 --leaf 4 --prefilter off --rays primary"

# check NAME ARGS...: 0 if the contract holds, else prints why.
check() {
  name=$1; shift
  rm -rf "$work"; mkdir -p "$work"
  printf 'keep' > "$work/existing.png"
  (cd "$work" && SPHERECULL_IMPORT_TIMEOUT=${TIMEOUT:-60} "$S" "$@" >"$root/stdout" 2>"$root/stderr")
  rc=$?
  lines=$(wc -l < "$root/stderr")
  why=""
  [ "$rc" -ne 0 ] || why="exit status 0"
  [ "$rc" -lt 128 ] || why="$why; killed by signal $((rc - 128))"
  [ "$lines" -eq 1 ] || why="$why; $lines lines on stderr"
  grep -q '^spherecull: ' "$root/stderr" || why="$why; stderr does not start with 'spherecull: '"
  left=$(ls -A "$work" | grep -v '^existing\.png$' | tr '\n' ' ')
  [ -z "$left" ] || why="$why; left behind: $left"
  [ "$(cat "$work/existing.png")" = keep ] || why="$why; existing.png changed"
  [ -L "$root/full" ] || { why="$why; the symlink to /dev/full was replaced"; ln -sf /dev/full "$root/full"; }
  [ -c /dev/full ] || why="$why; /dev/full is no longer a device"
  if [ -z "$why" ]; then
    return 0
  fi
  echo "  $name: ${why#; }" >&2
  sed 's/^/    stderr: /' "$root/stderr" | head -n 3 >&2
  return 1
}

ok() {
  if check "$@"; then pass=$((pass + 1)); echo "ok    $1"; else fail=$((fail + 1)); echo "FAIL  $1"; fi
}

# xfail REASON NAME ARGS...
xfail() {
  reason=$1; shift
  if check "$@" 2>/dev/null; then
    fail=$((fail + 1)); echo "XPASS $1 (now passes: remove the xfail mark: $reason)"
  else
    xfail=$((xfail + 1)); echo "xfail $1 ($reason)"
  fi
}

# ---- scenes that cannot be loaded, for every command that takes one
for cmd in render raster compare bench; do
  case $cmd in
    render) extra="-o out.png $SMALL_R" ;;
    raster) extra="-o out.png $SMALL_R" ;;
    compare) extra="$SMALL_C" ;;
    bench) extra="$SMALL_B" ;;
  esac
  ok "$cmd missing scene"        $cmd /nonexistent/scene.obj $extra
  ok "$cmd directory as scene"   $cmd "$root/in" $extra
  ok "$cmd empty file"           $cmd "$root/in/empty.obj" $extra
  ok "$cmd JSON syntax error"    $cmd "$root/in/syntax.json" $extra
  ok "$cmd JSON missing mesh"    $cmd "$root/in/missing_ref.json" $extra
  ok "$cmd JSON 1e9x1e9 image"   $cmd "$root/in/huge.json" $extra
  ok "$cmd bad index"            $cmd "$root/in/bad_index.obj" $extra
  ok "$cmd random bytes"         $cmd "$root/in/noise.stl" $extra
  ok "$cmd bad proc count"       $cmd proc:sphere:-5 $extra
  [ -f "$root/in/cut.cob" ] && ok "$cmd COB that aborts assimp" $cmd "$root/in/cut.cob" $extra
  [ -f "$root/in/segv.x" ] && ok "$cmd .x that crashes assimp" $cmd "$root/in/segv.x" $extra
done
# A cut SMD file loops forever inside assimp: the import time limit stops it.
if [ -r $MODELS/SMD/triangle.smd ]; then
  head -c 39 $MODELS/SMD/triangle.smd > "$root/in/cut.smd"
  TIMEOUT=1
  ok "render endless import (SMD)" render "$root/in/cut.smd" -o out.png $SMALL_R
  TIMEOUT=60
fi

# ---- outputs that cannot be written
for cmd in render raster; do
  ok "$cmd -o missing dir"       $cmd proc:sphere:200 -o /nonexistent/x.png $SMALL_R
  ok "$cmd -o read-only dir"     $cmd proc:sphere:200 -o $ro/x.png $SMALL_R
  ok "$cmd -o directory"         $cmd proc:sphere:200 -o "$root/in" $SMALL_R
  ok "$cmd -o symlink to device" $cmd proc:sphere:200 -o "$root/full" $SMALL_R
done
ok "raster --ids missing dir" raster proc:sphere:200 -o out.png --ids /nonexistent/ids.png $SMALL_R
ok "raster --depth read-only dir" raster proc:sphere:200 -o out.png --depth $ro/d.png $SMALL_R
ok "compare --csv missing dir" compare proc:sphere:200 $SMALL_C --csv /nonexistent/x.csv
ok "compare --json read-only dir" compare proc:sphere:200 $SMALL_C --json $ro/x.json
ok "bench --csv missing dir"     bench proc:sphere:200 $SMALL_B --csv /nonexistent/x.csv
ok "bench --csv symlink to device" bench proc:sphere:200 $SMALL_B --csv "$root/full"
ok "accuracy --csv missing dir"  accuracy --n 5 --csv /nonexistent/x.csv
ok "accuracy --csv read-only dir" accuracy --n 5 --csv $ro/x.csv
ok "accuracy --csv symlink to device" accuracy --n 5 --csv "$root/full"
# A full disk, as a file size limit of 512 bytes (writes fail with EFBIG,
# SIGXFSZ ignored): the write fails at its end, after the rendering; the old
# existing.png must stay and no temporary may be left.
cat > "$root/limited.sh" <<EOS
#!/bin/sh
ulimit -f 1
trap '' XFSZ
exec "$S" "\$@"
EOS
chmod +x "$root/limited.sh"
S_real=$S S=$root/limited.sh
ok "render -o over a file on a full disk" render proc:sphere:2000 -o existing.png --width 256 --height 256
S=$S_real

# ---- absurd numbers
for v in 0 1e9 -5 abc 1.5 99999999999999999999 ""; do
  ok "render --width '$v'"   render proc:sphere:200 -o out.png --width "$v" --height 16
  ok "raster --height '$v'"  raster proc:sphere:200 -o out.png --width 24 --height "$v"
  ok "compare --width '$v'"  compare proc:sphere:200 $SMALL_C --width "$v"
  ok "bench --size '${v}x$v'" bench proc:sphere:200 $SMALL_B --size "${v}x$v"
  ok "accuracy --n '$v'"     accuracy --n "$v"
done
ok "render 30000x30000"          render proc:sphere:200 -o out.png --width 30000 --height 30000
ok "render --leaf 0"             render proc:sphere:200 -o out.png $SMALL_R --leaf 0
ok "render --threads -1"         render proc:sphere:200 -o out.png $SMALL_R --threads -1
ok "render --ao 1e9"             render proc:sphere:200 -o out.png $SMALL_R --ao 1e9
ok "render --max-triangles 0"    render proc:sphere:200 -o out.png $SMALL_R --max-triangles 0
ok "render over --max-triangles" render proc:sphere:200 -o out.png $SMALL_R --max-triangles 10
ok "raster --fov 0"              raster proc:sphere:200 -o out.png $SMALL_R --fov 0
ok "raster --fov 1e9"            raster proc:sphere:200 -o out.png $SMALL_R --fov 1e9
ok "raster --eye nan"            raster proc:sphere:200 -o out.png $SMALL_R --eye nan,0,0
ok "compare --count 0"           compare proc:sphere:200 $SMALL_C --count 0
ok "compare --repeats 1e9"       compare proc:sphere:200 $SMALL_C --repeats 1e9
ok "compare --threads 0"         compare proc:sphere:200 $SMALL_C --threads 0
ok "bench --repeats 0"           bench proc:sphere:200 $SMALL_B --repeats 0
ok "bench --leaf 17"             bench proc:sphere:200 $SMALL_B --leaf 17
ok "bench --threads 1e9"         bench proc:sphere:200 $SMALL_B --threads 1e9
ok "bench-spheres --isa bogus"   bench-spheres --isa bogus
ok "bench-spheres --bogus"       bench-spheres --bogus
ok "render without a value"      render proc:sphere:200 -o out.png --width
ok "unknown command"             bogus

echo "cli_bad_input: $pass passed, $xfail expected failures, $fail failed"
[ "$fail" -eq 0 ]
