#!/usr/bin/env bash
# Mitsuba 3's example scenes (mitsuba-data's docs/scenes) through this renderer: renders each at one
# sample per pixel (`render SCENE --spp 1 -q`, from the scene's folder, as a user would) and writes
# the table of those that load and render and of the first error of the rest.
#
#   bash scripts/mitsuba-docs-scenes.sh MITSUBA_DATA_DIR [BUILD_DIR] [OUT_DIR]
#
# MITSUBA_DATA_DIR  a checkout of https://github.com/mitsuba-renderer/mitsuba-data (or its docs/scenes)
# BUILD_DIR         the build with tools/render (default: build)
# OUT_DIR           renders and the table docs-scenes.md (default: out/mitsuba-docs-scenes)
# Exit codes: 0 the table was made, 2 usage error.
set -uo pipefail

[ $# -ge 1 ] || { sed -n '6,11p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
data=$1 build=$(realpath "${2:-build}") out=${3:-out/mitsuba-docs-scenes}
dir=$data/docs/scenes
[ -d "$dir" ] || dir=$data
ls "$dir"/*.xml >/dev/null 2>&1 || { echo "no scenes in $dir" >&2; exit 2; }
[ -x "$build/tools/render" ] || { echo "no $build/tools/render (build it first)" >&2; exit 2; }
mkdir -p "$out"
out=$(realpath "$out")

ok=0 total=0 rows=""
for f in "$dir"/*.xml; do
  name=$(basename "$f" .xml)
  total=$((total + 1))
  if (cd "$dir" && timeout 300 "$build/tools/render" "$name.xml" --spp 1 -q -o "$out/$name.exr") >"$out/$name.log" 2>&1; then
    ok=$((ok + 1))
  else
    err=$(grep -m1 -i "error" "$out/$name.log" | sed 's/^error: //; s/ (supported: [^)]*)//' | cut -c1-200 | sed 's/</\&lt;/g; s/>/\&gt;/g; s/|/\\|/g')
    [ -n "$err" ] || err="exit code $(tail -c 200 "$out/$name.log" | tr '\n' ' ')"
    rows+="| \`$name.xml\` | $err |"$'\n'
  fi
done

{
  echo "$ok of $total scenes load and render (render --spp 1)."
  echo
  echo "| scene | first error |"
  echo "|---|---|"
  printf '%s' "$rows"
} >"$out/docs-scenes.md"
echo "$ok of $total load and render; table: $out/docs-scenes.md"
