#!/bin/sh
# The MPI driver on loopback. `mpirun -np N spherecull render`: the PNG
# equals the single-process one byte for byte (path tracer, direct
# integrator with AO, the depth view whose scale is global, Embree as the
# back end; 2 and 3 ranks); a rank that fails to load its scene makes the
# job exit non-zero with one line of ours and no hang; mpirun killed
# mid-render leaves no PNG. `mpirun -np N spherecull compare`: the CSV
# equals the single-process one apart from the timing columns (2 and 3
# ranks), and a rank that cannot load a scene fails the job with one line.
# `mpirun -np N spherecull bench`: the CSV equals the single-process one
# apart from the timing columns. Other commands refuse to run as N copies.
#
#   tests/mpi.sh SPHERECULL CORNELL_JSON MPI_BUILT(0|1)
set -u
S=${1:?usage: mpi.sh SPHERECULL CORNELL_JSON MPI_BUILT}
C=${2:?usage: mpi.sh SPHERECULL CORNELL_JSON MPI_BUILT}
if [ "${3:-0}" != 1 ]; then
  echo "skipped: this build has no MPI driver (SPHERECULL_MPI=OFF or no MPI found)"
  exit 77
fi
if ! command -v mpirun > /dev/null; then
  echo "skipped: no mpirun on PATH (scripts/setup.sh installs openmpi-bin)"
  exit 77
fi
# Open MPI refuses root unless told (CI runs as root); loopback only.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
dir=$(mktemp -d "${TMPDIR:-/tmp}/sc_mpi.XXXXXX") || exit 1
trap 'rm -rf "$dir"' EXIT INT TERM
cd "$dir" || exit 1
fail=0
no() { echo "FAIL  $*"; fail=1; }
mp() { n=$1; shift; timeout 120 mpirun -np "$n" "$S" "$@"; }

same() {   # NAME RENDER-OPTIONS...: 1 process against 2 and 3 ranks
  name=$1; shift
  before=$fail
  "$S" render -q "$C" --threads 1 -o "$name.1.png" "$@" || { no "$name: single process, exit status $?"; return; }
  for n in 2 3; do
    mp "$n" render -q "$C" --threads 1 -o "$name.$n.png" "$@" || { no "$name: $n ranks, exit status $?"; continue; }
    cmp -s "$name.1.png" "$name.$n.png" || no "$name: $n ranks give other PNG bytes than one process"
  done
  [ "$fail" = "$before" ] && echo "ok    $name: 1 process = 2 ranks = 3 ranks"
}
same path --width 96 --spp 4 --bounces 3
same direct --width 96 --integrator direct --ao 4
same depth --width 96 --integrator direct --debug depth
if "$S" compare --help | grep -q 'embree'; then
  same embree --width 96 --spp 2 --tracer embree
fi

# Rank 1 cannot read its scene (MPMD: other arguments per rank): every rank
# exits non-zero, we print one line, nothing is written, nobody hangs.
timeout 120 mpirun -np 1 "$S" render -q "$C" -o fail.png : -np 1 "$S" render -q "$dir/missing.json" -o fail.png \
  > out.txt 2> err.txt
rc=$?
before=$fail
[ "$rc" -ne 0 ] && [ "$rc" -ne 124 ] || no "a rank without its scene: exit status $rc (124 = hung)"
[ "$(grep -c '^spherecull:' err.txt)" -eq 1 ] || no "a rank without its scene: $(grep -c '^spherecull:' err.txt) lines of ours"
grep -q 'missing.json' err.txt || no "a rank without its scene: the line does not name the file"
[ ! -e fail.png ] || no "a rank without its scene: fail.png written"
[ "$fail" = "$before" ] && echo "ok    a rank without its scene: exit $rc, one line: $(grep '^spherecull:' err.txt)"

# Killed mid-render: no PNG, no temporary file.
mpirun -np 2 "$S" render -q "$C" --threads 1 --width 256 --spp 65536 -o killed.png > /dev/null 2>&1 &
pid=$!
sleep 2
kill -TERM "$pid" 2> /dev/null
wait "$pid"
if [ -z "$(ls | grep killed)" ]; then
  echo "ok    mpirun killed mid-render: nothing written"
else
  no "mpirun killed mid-render left $(ls | grep killed)"
fi

# compare: the same rows as one process, apart from what timing decides.
# Dropped: the timing columns, found by name in the header, and Embree's
# bytes per triangle (its builder's allocations depend on how many threads
# it got, which the load on the machine decides, with or without MPI).
notime() {
  awk 'BEGIN { FS = "," }
       NR == 1 { for (i = 1; i <= NF; i++) {
                   drop[i] = ($i ~ /^(mrays_per_s|speed_vs_embree|best_embree|best_embree_tracer|loops|build_s)$/)
                   if ($i == "tracer") tc = i
                   if ($i == "bytes_per_tri") bc = i } }
       NR > 1 && $tc ~ /^embree/ { $bc = "" }
       { line = ""; for (i = 1; i <= NF; i++) if (!drop[i]) line = line (line == "" ? "" : ",") $i; print line }' "$1"
}
tracers=spherecull-off,spherecull-exact
if "$S" compare --help | grep -q 'embree-high'; then tracers=$tracers,embree,embree-high; fi
cmpargs="$C proc:sphere:2000 --rays primary,shadow,diffuse,random,adversarial --tracers $tracers --threads 1
         --repeats 1 --min-time 0 --oracle-rays 200 --width 48 --count 1500"
before=$fail
# shellcheck disable=SC2086
"$S" compare $cmpargs --csv c1.csv > c1.txt 2>&1 || no "compare, one process: exit status $?"
for n in 2 3; do
  # shellcheck disable=SC2086
  mp "$n" compare $cmpargs --csv "c$n.csv" > "c$n.txt" 2>&1 || { no "compare, $n ranks: exit status $?"; continue; }
  notime c1.csv > c1.cut
  notime "c$n.csv" > "c$n.cut"
  [ "$(wc -l < c1.cut)" -gt 20 ] || no "compare: only $(wc -l < c1.cut) lines in the CSV"
  cmp -s c1.cut "c$n.cut" || { no "compare, $n ranks: the CSV differs from one process's beyond timing"; diff c1.cut "c$n.cut" | head -5; }
done
[ "$fail" = "$before" ] && echo "ok    compare: 1 process = 2 ranks = 3 ranks, $(($(wc -l < c1.cut) - 1)) rows apart from timing"

before=$fail
timeout 120 mpirun -np 1 "$S" compare "$C" --tracers spherecull-off --threads 1 --oracle-rays 10 --width 16 : \
  -np 1 "$S" compare "$dir/gone.obj" --tracers spherecull-off --threads 1 --oracle-rays 10 --width 16 \
  > out.txt 2> err.txt
rc=$?
[ "$rc" -ne 0 ] && [ "$rc" -ne 124 ] || no "compare, a rank without its scene: exit status $rc (124 = hung)"
[ "$(grep -c '^spherecull:' err.txt)" -eq 1 ] || no "compare, a rank without its scene: $(grep -c '^spherecull:' err.txt) lines of ours"
[ "$fail" = "$before" ] && echo "ok    compare, a rank without its scene: exit $rc, one line: $(grep '^spherecull:' err.txt)"

# bench: the same CSV as one process, apart from what timing and Embree's
# thread count decide.
notime_bench() {
  awk 'BEGIN { FS = "," }
       NR == 1 { for (i = 1; i <= NF; i++)
                   drop[i] = ($i ~ /^(mrays|embree_mrays|ratio|cycle_ratio|build_ms|embree_bvh_bytes_per_tri|embree_total_bytes_per_tri)$/) }
       { line = ""; for (i = 1; i <= NF; i++) if (!drop[i]) line = line (line == "" ? "" : ",") $i; print line }' "$1"
}
benchargs="$C proc:sphere:3000 --rays primary,shadow,diffuse,random --threads 1 --leaf 4,8 --prefilter off,compact
           --repeats 1 --count 1500 --size 48x36"
before=$fail
# shellcheck disable=SC2086
"$S" bench $benchargs --csv b1.csv > b1.txt 2>&1 || no "bench, one process: exit status $?"
notime_bench b1.csv > b1.cut
for n in 2 3; do
  # shellcheck disable=SC2086
  mp "$n" bench $benchargs --csv "b$n.csv" > "b$n.txt" 2>&1 || { no "bench, $n ranks: exit status $?"; continue; }
  notime_bench "b$n.csv" > "b$n.cut"
  cmp -s b1.cut "b$n.cut" || { no "bench, $n ranks: the CSV differs from one process's beyond timing"; diff b1.cut "b$n.cut" | head -5; }
done
[ "$(wc -l < b1.cut)" -gt 20 ] || no "bench: only $(wc -l < b1.cut) lines in the CSV"
[ "$fail" = "$before" ] && echo "ok    bench: 1 process = 2 ranks = 3 ranks, $(($(wc -l < b1.cut) - 1)) rows apart from timing"

# A command that does not share its work refuses to run as N copies.
timeout 60 mpirun -np 2 "$S" bench-spheres > out.txt 2> err.txt
rc=$?
if [ "$rc" -ne 0 ] && [ "$rc" -ne 124 ] && [ "$(grep -c '^spherecull:' err.txt)" -eq 1 ]; then
  echo "ok    bench-spheres under mpirun: refused, one line: $(grep '^spherecull:' err.txt)"
else
  no "bench-spheres under mpirun: exit status $rc, $(grep -c '^spherecull:' err.txt) lines of ours"
fi

exit $fail
