#!/usr/bin/env bash
# Speed figures for the foundation (render and raybench), on the default Cornell box at 512x512,
# 64 spp, max depth 8, 2 threads, and on the same box with a ~1M-triangle displaced sphere.
# Prints the figures; run after `bash scripts/setup.sh build`.
set -euo pipefail
cd "$(dirname "$0")/.."
B=build/tools
mesh=scenes/bench/displaced-sphere.ply
[ -f "$mesh" ] || $B/meshgen "$mesh" --rings 708 --segments 708
for scene in scenes/cornell-box.xml scenes/bench/cornell-displaced-sphere.xml; do
  echo "== $scene"
  $B/render "$scene" -D res=512 --spp 64 --max-depth 8 --threads 2 --quiet -o out/bench/$(basename "$scene" .xml).exr
  # The yardstick: the path tracer's own rays (same settings), cast bare. The synthetic mix (one
  # camera, bounce and shadow ray per pixel) is printed too, for comparison with earlier figures.
  $B/raybench "$scene" -D res=512 --threads 2 --passes 8 --max-depth 8
  $B/raybench "$scene" -D res=512 --threads 2 --passes 8 --mode synthetic
done
