#!/usr/bin/env bash
# How each tracer's cost grows with the scene: `spherecull compare` on grids
# of copies of the Stanford bunny (proc:grid:cache:bunny00.off:N) from 100k to
# 32M triangles, primary, shadow, diffuse and random rays, our default tracer
# against Embree's medium and high builds, 1 and 2 threads. Writes
# out/cost-growth.csv (compare's rows, with build_s) and
# out/cost-growth.png (Mrays/s and build seconds against triangles), and
# prints the table. A timing run: nothing else should run on the machine.
#
#   scripts/cost-growth.sh [SIZES...]     (default: 100k 1M 4M 16M 32M)
#   scripts/cost-growth.sh --report       (table and plot again from out/cost-growth.csv)
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "${1:-}" != "--report" ]; then
  ./scripts/setup.sh
  ./scripts/fetch-meshes.sh
  ./scripts/build.sh
fi
sc=./build/src/cli/spherecull
report_only=0
if [ "${1:-}" = "--report" ]; then report_only=1; shift; fi
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(100k 1M 4M 16M 32M)
mkdir -p out
tmp=$(mktemp -d "${TMPDIR:-/tmp}/sc_growth.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
first=1
[ $report_only -eq 1 ] || for n in "${sizes[@]}"; do
  echo "# proc:grid:cache:bunny00.off:$n" >&2
  "$sc" compare "proc:grid:cache:bunny00.off:$n" --rays primary,shadow,diffuse,random \
      --tracers spherecull-off,embree,embree-high --threads 1,2 --repeats 3 --oracle-rays 0 \
      --count 262144 --csv "$tmp/$n.csv" > "$tmp/$n.txt"
  if [ $first -eq 1 ]; then cat "$tmp/$n.csv"; first=0; else tail -n +2 "$tmp/$n.csv"; fi
done > "$tmp/all.csv"
[ $report_only -eq 1 ] || mv "$tmp/all.csv" out/cost-growth.csv

# Table: one line per size x rays x threads, ours against the better Embree
# (POSIX awk: Debian's default awk is mawk).
{
  printf "%10s %-8s %3s %9s %9s %9s %7s %8s %8s %8s %6s %6s\n" triangles rays thr ours embree e-high xBest \
         build e-build eh-build B/tri eB/tri
  awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; next }
           { k = $c["triangles"] "," $c["rays"] "," $c["threads"]; keys[k] = 1
             m[k "," $c["tracer"]] = $c["mrays_per_s"]; b[k "," $c["tracer"]] = $c["build_s"]
             bpt[k "," $c["tracer"]] = $c["bytes_per_tri"] }
           END {
             for (k in keys) {
               split(k, f, ",")
               o = m[k ",spherecull-off"]; e = m[k ",embree"]; h = m[k ",embree-high"]
               best = e > h ? e : h
               printf "%10d %-8s %3d %9.2f %9.2f %9.2f %7.3f %8.2f %8.2f %8.2f %6.1f %6.1f\n", f[1], f[2], f[3],
                      o, e, h, (best > 0 ? o / best : 0), b[k ",spherecull-off"], b[k ",embree"], b[k ",embree-high"],
                      bpt[k ",spherecull-off"], bpt[k ",embree"]
             }
           }' out/cost-growth.csv | sort -k1,1n -k2,2 -k3,3n
} | tee out/cost-growth.txt

# Plot: Mrays/s per ray kind (1 thread) and build seconds, against triangles.
for t in spherecull-off embree embree-high; do
  for r in primary shadow diffuse random; do
    awk -F, -v t="$t" -v r="$r" 'NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; next }
         $c["tracer"] == t && $c["rays"] == r && $c["threads"] == 1 { print $c["triangles"], $c["mrays_per_s"], $c["build_s"] }' \
        out/cost-growth.csv | sort -n > "$tmp/$t-$r.dat"
  done
done
gnuplot <<GP
set terminal pngcairo size 1200,500 font ",10"
set output "out/cost-growth.png.tmp"
set multiplot layout 1,2 title "spherecull vs Embree 3.13.5 on proc:grid:cache:bunny00.off:N (1 thread)"
set logscale x
set xlabel "triangles"
set ylabel "Mrays/s"
set key outside bottom center horizontal
set grid
plot for [r in "primary shadow diffuse random"] "$tmp/spherecull-off-".r.".dat" using 1:2 with linespoints title "ours ".r, \
     for [r in "primary shadow diffuse random"] "$tmp/embree-high-".r.".dat" using 1:2 with linespoints dashtype 2 title "embree-high ".r
set logscale y
set ylabel "build seconds (every CPU)"
plot "$tmp/spherecull-off-primary.dat" using 1:3 with linespoints title "ours", \
     "$tmp/embree-primary.dat" using 1:3 with linespoints title "embree (medium)", \
     "$tmp/embree-high-primary.dat" using 1:3 with linespoints title "embree-high"
unset multiplot
GP
mv out/cost-growth.png.tmp out/cost-growth.png
echo "wrote out/cost-growth.csv, out/cost-growth.txt, out/cost-growth.png"
