#!/usr/bin/env bash
# Renders the converged references of the hard-case suite (scenes/hard/*.xml) into scenes/hard/refs/:
# <scene>.exr (64x64, VCM, REF_TIME seconds in 2 chunks), <scene>.json (the reference tool's record:
# command, configuration, spp, seeds and the SHA-256 of the scene and every file it reads, with
# -D res=64) and <scene>.png. The result is committed (about 60 KB per scene); test_hard_scenes
# fails when a scene no longer matches its reference's hash, so a changed scene needs this script.
# VCM samples every path class of the suite but L S E and L S S E (a point light seen through
# glass or in a mirror by the pinhole), which only a regulariser renders: the references lack it.
# Usage: bash scripts/make-references.sh [SCENE.xml ...]; environment: REF_TIME (seconds, 60).
set -euo pipefail
cd "$(dirname "$0")/.."
REF_TIME=${REF_TIME:-60}
B=${LT_BUILD_DIR:-build}
cmake -S . -B "$B" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$B" --target reference >/dev/null
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(scenes/hard/*.xml)
for s in "${scenes[@]}"; do
  stem=$(basename "$s" .xml)
  "$B/tools/reference" "$s" -D res=64 -c vcm --time "$REF_TIME" --chunks 2 --seed 20261125 --clean \
    -o "scenes/hard/refs/$stem.exr"
done
