#!/bin/sh
# The command line's contract: --version, 'help CMD' equal to 'CMD --help'
# in one layout, --opt=value and --, one error line for usage errors,
# output files with the umask's mode, and CSV fields quoted.
#
#   tests/cli_options.sh path/to/spherecull VERSION
set -u
S=${1:?usage: cli_options.sh SPHERECULL VERSION}
V=${2:?usage: cli_options.sh SPHERECULL VERSION}
case $S in /*) ;; *) S=$(cd "$(dirname "$S")" && pwd)/$(basename "$S") ;; esac
dir=$(mktemp -d "${TMPDIR:-/tmp}/sc_cli_opts.XXXXXX") || exit 1
trap 'rm -rf "$dir"' EXIT INT TERM
cd "$dir" || exit 1
fail=0
no() { echo "FAIL  $*"; fail=1; }

[ "$("$S" --version)" = "spherecull $V" ] || no "--version does not print 'spherecull $V'"

for c in accuracy bench bench-render bench-spheres compare raster raster-check render; do
  "$S" help "$c" > help.txt || no "help $c: exit status $?"
  "$S" "$c" --help > dash.txt || no "$c --help: exit status $?"
  cmp -s help.txt dash.txt || no "help $c differs from $c --help"
  head -n 1 help.txt | grep -q "^usage: spherecull $c " || no "$c --help: first line is not 'usage: spherecull $c ...'"
  grep -q '^options:$' help.txt || no "$c --help: no 'options:' section"
  grep -q '^  -h, --help              this help$' help.txt || no "$c --help: the help line is not in the common layout"
done
"$S" help render | grep -q -- '--leaf N .*(default: 8)$' || no "render --help does not state the --leaf default"

# usage errors: exit 2, exactly one line on stderr
one_line() {
  expect=$1; shift
  "$S" "$@" > /dev/null 2> err.txt
  rc=$?
  [ "$rc" -eq "$expect" ] || no "$*: exit status $rc, wanted $expect"
  [ "$(wc -l < err.txt)" -eq 1 ] || no "$*: $(wc -l < err.txt) lines on stderr"
  grep -q '^spherecull: ' err.txt || no "$*: stderr does not start with 'spherecull: '"
}
one_line 2 help no-such-command
one_line 2 render proc:sphere:200 --width
one_line 2 render proc:sphere:200 -o x.png --width=0
one_line 2 compare proc:sphere:200 --bogus
one_line 2 bench proc:sphere:200 --threads=1,,2
one_line 2 bench proc:sphere:200 --packet 4
one_line 2 raster-check proc:sphere:200 --prefilter=sometimes

# bench --packet 16 runs our packets against Embree's and says so
"$S" bench proc:sphere:2000 --packet 16 --repeats 1 --size 32x32 --threads 1 --leaf 4 --prefilter off,circum \
  > pk.txt || no "bench --packet 16: exit status $?"
if grep -q '^# embree: 3' pk.txt; then
  grep -q 'rtcIntersect16' pk.txt || no "bench --packet 16 does not name Embree's packets"
fi
grep -q '^primary .* circum ' pk.txt || no "bench --packet 16 printed no circum row"

# bench times diffuse and random rays too (closest hit; checked against brute force first)
"$S" bench proc:sphere:2000 --rays diffuse,random --count 500 --repeats 1 --size 32x32 --threads 1 --leaf 4 \
  --prefilter off > dr.txt || no "bench --rays diffuse,random: exit status $?"
grep -q '^diffuse .* off ' dr.txt || no "bench --rays diffuse,random printed no diffuse row"
grep -q '^random .* off ' dr.txt || no "bench --rays diffuse,random printed no random row"
grep -q ' 500 random rays ' dr.txt || no "bench --count 500 did not make 500 random rays"
one_line 2 bench proc:sphere:200 --rays primary,bogus

# --opt=value and -- (an operand after -- is never an option)
"$S" accuracy --n=3 --seed=2 > acc.txt || no "accuracy --n=3 --seed=2: exit status $?"
grep -q '3 triangles per family, seed 2' acc.txt || no "accuracy --n=3 --seed=2 did not take the values"
umask 027
"$S" render -q --output=r.png --width=8 --height=6 -- proc:sphere:200 || no "render ... -- SCENE: exit status $?"
[ -f r.png ] || no "render --output=r.png wrote no file"
[ "$(stat -c %a r.png 2>/dev/null)" = 640 ] || no "r.png has mode $(stat -c %a r.png 2>/dev/null), wanted 640 (umask 027)"

# a scene name with a comma stays one CSV field
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n' > 'a,b.obj'
"$S" compare 'a,b.obj' --repeats 1 --count 64 --oracle-rays 8 --width 16 --rays primary \
    --tracers spherecull-off --threads 1 --csv=c.csv > /dev/null 2>&1 || no "compare a,b.obj: exit status $?"
sed -n 2p c.csv | grep -q '^"a,b.obj",4,primary,spherecull-off,' || no "compare --csv: scene 'a,b.obj' not quoted: $(sed -n 2p c.csv)"
[ "$(stat -c %a c.csv 2>/dev/null)" = 640 ] || no "c.csv has mode $(stat -c %a c.csv 2>/dev/null), wanted 640"
[ "$(ls -A | grep -c tmp)" -eq 0 ] || no "temporary files left: $(ls -A | grep tmp)"

# the yardstick in every compare row: the Embree it loaded, the faster of
# Embree's medium and high builds (checked here from the rows themselves),
# the MXCSR mode, the loops per timed run and the build time
if "$S" compare --help | grep -q 'embree-high'; then
  cp 'a,b.obj' tet.obj      # no comma in the scene field: the checks below split on commas
  "$S" compare tet.obj --repeats 1 --count 64 --oracle-rays 0 --width 16 --rays primary,random \
      --tracers spherecull-off,embree,embree-high --threads 1 --min-time 0.01 --csv=y.csv >y.err 2>/dev/null ||
    no "compare with embree, embree-high: exit status $?"
  grep -q '^embree: 3\.[0-9]*\.[0-9]* /.*libembree3' y.err || no "compare does not name the Embree it loaded: $(cat y.err)"
  awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; next }
           { m[$c["rays"] "/" $c["tracer"]] = $c["mrays_per_s"]; row[NR] = $0 }
           END {
             bad = 0
             for (r in row) {
               split(row[r], f, ",")
               if (f[c["tracer"]] != "spherecull-off") continue
               k = f[c["rays"]]; e = m[k "/embree"]; h = m[k "/embree-high"]
               best = e > h ? e : h; name = e > h ? "embree" : "embree-high"
               want = f[c["mrays_per_s"]] / best
               if (f[c["best_embree_tracer"]] != name) { print "best_embree_tracer " f[c["best_embree_tracer"]] ", wanted " name; bad = 1 }
               # the CSV rounds Mrays/s to 3 decimals: a few per cent on the
               # slow rows of a sanitizer build
               if (f[c["best_embree"]] - want > 0.05 * want || want - f[c["best_embree"]] > 0.05 * want) { print "best_embree " f[c["best_embree"]] ", wanted " want; bad = 1 }
               # speed_vs_embree is written with 3 decimals, best_embree with 4 digits
               if (f[c["best_embree"]] > f[c["speed_vs_embree"]] + 0.0006) { print "best_embree " f[c["best_embree"]] " above speed_vs_embree " f[c["speed_vs_embree"]]; bad = 1 }
               if (f[c["embree_build"]] !~ /libembree3/) { print "embree_build " f[c["embree_build"]]; bad = 1 }
               if (f[c["mxcsr"]] != "ftz" || f[c["loops"]] < 1) { print "mxcsr/loops " f[c["mxcsr"]] " " f[c["loops"]]; bad = 1 }
               if (!(f[c["build_s"]] > 0)) { print "build_s " f[c["build_s"]]; bad = 1 }
               n++
             }
             if (n != 2) { print n " spherecull-off rows"; bad = 1 }
             exit bad
           }' y.csv > y.out || no "compare yardstick columns: $(cat y.out)"
fi
"$S" bench 'a,b.obj' --instances many > /dev/null 2>&1; [ $? -eq 2 ] || no "bench --instances many: not a usage error"
"$S" compare 'a,b.obj' --instances many > /dev/null 2>&1; [ $? -eq 2 ] || no "compare --instances many: not a usage error"
# a scene with instances is compared through them (the instances column),
# or flattened on request
cat > inst.json <<'JSON'
{ "meshes": [ { "file": "tet.obj", "instances": [ { "translate": [0, 0, 0] }, { "translate": [3, 0, 0], "rotate": [0, 40, 0] } ] } ] }
JSON
cp 'a,b.obj' tet.obj
for mode in trace flat; do
  "$S" compare inst.json --instances $mode --repeats 1 --count 64 --oracle-rays 16 --width 16 --rays primary \
      --tracers spherecull-exact --threads 1 --min-time 0 --csv=i.csv > /dev/null 2>&1 || no "compare --instances $mode: exit status $?"
  want=2; [ $mode = flat ] && want=0
  awk -F, -v want=$want 'NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; next }
       { n++; if ($c["instances"] != want || $c["hit_miss_disagree"] != 0 || $c["primid_disagree"] != 0) bad = 1 }
       END { exit bad || n != 1 }' i.csv || no "compare --instances $mode: $(cat i.csv)"
done
"$S" bench inst.json --repeats 1 --threads 1 --leaf 8 --prefilter off --size 16x16 --count 64 > b.out 2>&1 ||
  no "bench inst.json: exit status $?"
grep -q 'traced through 2 instances' b.out || no "bench inst.json: not through the instances: $(cat b.out)"
"$S" bench inst.json --packet 16 --repeats 1 --threads 1 --leaf 8 --prefilter off --size 16x16 --count 64 2> b.out >/dev/null
[ $? -eq 1 ] && [ "$(grep -c . b.out)" -eq 1 ] || no "bench --packet 16 through instances: not one error line: $(cat b.out)"
"$S" compare 'a,b.obj' --mxcsr fast > /dev/null 2>&1; [ $? -eq 2 ] || no "compare --mxcsr fast: not a usage error"
"$S" compare 'a,b.obj' --min-time -1 > /dev/null 2>&1; [ $? -eq 2 ] || no "compare --min-time -1: not a usage error"

[ "$fail" -eq 0 ] && echo "cli_options: all passed"
exit "$fail"
