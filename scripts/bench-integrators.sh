#!/usr/bin/env bash
# Issue-3 benchmark: (A) seconds per iteration at 512x512, 2 threads, max depth 8, for PT, BPT, LT
# and VCM on the Cornell box and its mirror-sphere, glass-sphere and point-in-glass variants;
# (B) relMSE against a VCM reference after equal time for each integrator (bench tool).
# Usage: bash scripts/bench-integrators.sh [equal-time seconds (10)] [reference seconds (60)]
#        (equal-time seconds 0: part A only). REPEAT=N (default 3): part A runs each render N
#        times and reports the fastest, because timings on a shared machine vary by up to ~30%
#        from run to run (the minimum is the least disturbed run).
set -euo pipefail
cd "$(dirname "$0")/.."
T=${1:-10}
REF=${2:-60}
REPEAT=${REPEAT:-3}
B=build/tools
scenes=(scenes/cornell-box.xml scenes/cornell-box-mirror-sphere.xml scenes/cornell-box-glass-sphere.xml
        scenes/cornell-box-point-in-glass.xml)
mkdir -p out/bench-integrators
echo "| scene | pt s/iter | bpt s/iter | lt s/iter | vcm s/iter | vcm/bpt |   (fastest of $REPEAT runs)"
echo "|---|---|---|---|---|---|"
for s in "${scenes[@]}"; do
  row="| $(basename "$s" .xml) |"
  declare -A t=()
  for i in pt bpt lt vcm; do
    best=""
    for r in $(seq "$REPEAT"); do
      $B/render "$s" -D res=512 --integrator $i --spp 4 --max-depth 8 --threads 2 --quiet \
        -o out/bench-integrators/$(basename "$s" .xml)-$i.exr --stats-json out/bench-integrators/stats.json > /dev/null
      v=$(python3 -c "import json;d=json.load(open('out/bench-integrators/stats.json'));print('%.3f'%(d['seconds']/d['spp']))")
      best=$(python3 -c "print('%.3f' % min(float('$v'), float('${best:-$v}')))")
    done
    t[$i]=$best
    row="$row ${t[$i]} |"
  done
  row="$row $(python3 -c "print('%.2f'%(${t[vcm]}/${t[bpt]}))") |"
  echo "$row"
done
[ "$T" = 0 ] && exit 0
args=()
for s in "${scenes[@]}"; do args+=(--scenes "$s"); done
bash scripts/bench.sh "${args[@]}" --integrators pt,bpt,lt,vcm --time "$T" --res 128 --ref-time "$REF" \
  --ref-config vcm -o out/bench-integrators/BENCHMARKS-integrators.md
