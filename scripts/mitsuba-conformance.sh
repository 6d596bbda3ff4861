#!/usr/bin/env bash
# Mitsuba 3's render tests as a conformance suite: renders every scene of a mitsuba-data checkout's
# tests/scenes/*/*.xml (participating media excepted) the way Mitsuba's src/render/tests/test_renders.py
# does and applies its per-pixel z-test against the RGB reference refs/<name>_ref_rgb.exr with its
# per-sample variance refs/<name>_ref_rgb_var.exr (imgcompare --ztest, docs/tools.md).
#
#   bash scripts/mitsuba-conformance.sh [--strict] [--expect FILE] [--threads T] [--only REGEX]
#                                       MITSUBA_DATA_DIR [BUILD_DIR] [OUT_DIR]
#
# MITSUBA_DATA_DIR  a checkout of https://github.com/mitsuba-renderer/mitsuba-data (the folder holding
#                   tests/scenes; the tests/scenes folder itself is accepted too). Not shipped here.
# BUILD_DIR         the build with tools/render and tools/imgcompare (default: build)
# OUT_DIR           renders, logs, p-value maps and the table conformance.md (default:
#                   out/mitsuba-conformance)
# --strict          exit 1 when a tested scene does not pass (skipped scenes do not count)
# --expect FILE     exit 1 when a scene FILE lists (one path relative to tests/scenes per line, '#'
#                   comments) does not pass; a listed scene missing from the checkout is only warned of
# --threads T       render threads (default 2)
# --only REGEX      only the scenes whose path relative to tests/scenes matches REGEX (grep -E)
# Exit codes: 0 the table was made (whatever it says), 1 --strict or --expect found a scene that does
# not pass, 2 usage error (bad option, no tests/scenes, tools not built).
#
# What test_renders.py does, and this script with it, per scene <name>_<integrator>.xml:
#  - reference refs/<name>_ref_rgb.exr and refs/<name>_ref_rgb_var.exr (skipped when missing);
#  - spp = 2000000 // (reference pixels) (a sample budget: not the scene's spp, not the reference's);
#  - the scene is loaded with the parameters spp=<spp> and integrator=<integrator> (here -D spp=N
#    -D integrator=NAME and --spp N; relative paths resolve against the scene file's folder);
#  - z-test in XYZ, variance floored at 1e-4, two-sided p-value, Sidak level
#    1 - 0.99^(1/pixels), pass when (passing values)/3 >= 0.9975 x pixels (tools/ztest.h).
# Integrator names: 'path' and 'ptracer' are ours (pt, lt); the loader reads Mitsuba's 'direct' as path
# tracing with max depth 2 (the same paths and expectation) and 'moment' as the integrator nested in it.
# Participating-media scenes are listed as skipped: this renderer has no media (out of scope).
set -uo pipefail

usage() {
  sed -n '7,21p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
}

strict=0 expect="" threads=2 only=""
args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --strict) strict=1 ;;
    --expect) [ $# -ge 2 ] || usage; expect="$2"; shift ;;
    --threads) [ $# -ge 2 ] || usage; threads="$2"; shift ;;
    --only) [ $# -ge 2 ] || usage; only="$2"; shift ;;
    -h|--help) usage ;;
    -*) echo "mitsuba-conformance: unknown option $1" >&2; usage ;;
    *) args+=("$1") ;;
  esac
  shift
done
[ ${#args[@]} -ge 1 ] && [ ${#args[@]} -le 3 ] || usage
[[ "$threads" =~ ^[0-9]+$ ]] || { echo "mitsuba-conformance: --threads needs a number (got '$threads')" >&2; exit 2; }

repo=$(cd "$(dirname "$0")/.." && pwd)
data="${args[0]}"
build="${args[1]:-$repo/build}"
out="${args[2]:-$repo/out/mitsuba-conformance}"

if [ -d "$data/tests/scenes" ]; then scenes_dir="$data/tests/scenes"
elif [ -d "$data" ] && [ "$(basename "$data")" = scenes ]; then scenes_dir="$data"
else echo "mitsuba-conformance: $data has no tests/scenes (give the mitsuba-data checkout)" >&2; exit 2
fi
scenes_dir=$(cd "$scenes_dir" && pwd)
render="$(cd "$build" 2>/dev/null && pwd)/tools/render"
imgcompare="$(cd "$build" 2>/dev/null && pwd)/tools/imgcompare"
for t in "$render" "$imgcompare"; do
  [ -x "$t" ] || { echo "mitsuba-conformance: $t not found: build it (ninja -C $build render imgcompare)" >&2; exit 2; }
done
if [ -n "$expect" ] && [ ! -r "$expect" ]; then
  echo "mitsuba-conformance: cannot read the expectation file $expect" >&2; exit 2
fi
[ -z "$expect" ] || expect="$(cd "$(dirname "$expect")" && pwd)/$(basename "$expect")"
mkdir -p "$out" || exit 2
out=$(cd "$out" && pwd)

# One row per scene: scene, integrator, spp, status, details, short reason (tab-separated in $rows).
rows=()
n_pass=0 n_fail=0 n_load=0 n_skip=0 n_err=0
declare -A status_of

# The first line of a file matching a pattern, without the "error: " prefix ("" if none).
first_line() { grep -m1 -E "$2" "$1" 2>/dev/null | sed -e 's/^error: //' -e 's/^warning: //'; }

g3() { awk -v x="$1" 'BEGIN { printf "%.3g", x }'; }  # a number with 3 significant digits
field() { sed -n "s/^$1: //p" "$zlog"; }  # a line "NAME: value" of the z-test's output

# The short reason of the summary table: a loader error without its file, line, element and list of
# what is supported; a z-test failure's counts.
short_reason() {  # status details
  case "$1" in
    pass) echo "" ;;
    FAIL) echo "${2%%;*}" ;;
    "does not load") sed -E -e 's/^[^ ]+:[0-9]+: //' -e 's/^<[^>]*>:? ?//' -e 's/ \(supported:.*$//' \
                            -e 's/; use .*$//' <<<"$2" ;;
    *) echo "$2" ;;
  esac
}

add_row() {  # scene integrator spp status details
  rows+=("$1"$'\t'"$2"$'\t'"$3"$'\t'"$4"$'\t'"$5"$'\t'"$(short_reason "$4" "$5")")
  status_of["$1"]="$4"
  printf '%-58s %-8s %s\n' "$1" "$4" "$5"
}

cd "$scenes_dir" || exit 2
mapfile -t scene_files < <(ls -1 -- */*.xml 2>/dev/null | LC_ALL=C sort)
for rel in "${scene_files[@]}"; do
  if [ -n "$only" ] && ! grep -qE -- "$only" <<<"$rel"; then continue; fi
  folder=$(dirname "$rel")
  base=$(basename "$rel" .xml)
  integrator=${base##*_}
  name=${base%_*}
  if [ "$folder" = participating_media ]; then
    add_row "$rel" "$integrator" "-" "skipped" "participating media: not supported by this renderer (out of scope)"
    n_skip=$((n_skip + 1)); continue
  fi
  ref="$folder/refs/${name}_ref_rgb.exr"
  var="$folder/refs/${name}_ref_rgb_var.exr"
  if [ ! -f "$ref" ] || [ ! -f "$var" ]; then
    add_row "$rel" "$integrator" "-" "skipped" "no reference: $ref and $var"
    n_skip=$((n_skip + 1)); continue
  fi
  pixels=$("$imgcompare" "$ref" "$ref" --metric mean --json 2>/dev/null | sed -n 's/.*"pixels": \([0-9]*\).*/\1/p')
  if ! [[ "$pixels" =~ ^[1-9][0-9]*$ ]]; then
    add_row "$rel" "$integrator" "-" "error" "cannot read the reference $ref"
    n_err=$((n_err + 1)); continue
  fi
  spp=$((2000000 / pixels))
  mkdir -p "$out/$folder"
  img="$out/$folder/$base.exr" log="$out/$folder/$base.log"
  extra=()
  t0=$(date +%s.%N)
  "$render" "$rel" --spp "$spp" -D "spp=$spp" -D "integrator=$integrator" "${extra[@]}" --threads "$threads" \
    --quiet -o "$img" >"$log" 2>&1
  rc=$?
  seconds=$(awk -v a="$t0" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
  if [ $rc -ne 0 ]; then
    msg=$(first_line "$log" '^error')
    [ -n "$msg" ] || msg=$(grep -v '^warning' "$log" | head -n1)
    if [ $rc -eq 2 ]; then
      add_row "$rel" "$integrator" "$spp" "does not load" "$msg"
      n_load=$((n_load + 1))
    else
      add_row "$rel" "$integrator" "$spp" "error" "render exit code $rc: $msg"
      n_err=$((n_err + 1))
    fi
    continue
  fi
  zlog="$out/$folder/$base.ztest.txt"
  "$imgcompare" "$img" "$ref" --ztest --ref-var "$var" --spp "$spp" --pvalue-map "$out/$folder/${base}_pvalue.exr" \
    >"$zlog" 2>&1
  zrc=$?
  warn=$(first_line "$log" '^warning')
  wcount=$(grep -c '^warning' "$log")
  note=""
  [ "$wcount" -gt 0 ] && note="; $wcount loader warning(s), first: $warn"
  case $zrc in
    0)
      add_row "$rel" "$integrator" "$spp" "pass" \
        "$(field ztest_failing_values) failing values; min p $(g3 "$(field ztest_min_pvalue)") > alpha $(g3 "$(field ztest_sidak_level)"); ${seconds} s$([ "$wcount" -gt 0 ] && echo "; $wcount loader warning(s): $base.log")"
      n_pass=$((n_pass + 1)) ;;
    3)
      add_row "$rel" "$integrator" "$spp" "FAIL" \
        "$(field ztest_failing_values) failing values in $(field ztest_failing_pixels) pixels (at most $(g3 "$(field ztest_allowed_failing_values)") pass); min p $(g3 "$(field ztest_min_pvalue)") at $(field ztest_min_pvalue_at | sed 's/ image.*//'), alpha $(g3 "$(field ztest_sidak_level)"), max z $(g3 "$(field ztest_max_z)")$note"
      n_fail=$((n_fail + 1)) ;;
    *)
      add_row "$rel" "$integrator" "$spp" "error" "imgcompare exit code $zrc: $(grep -m1 error "$zlog")"
      n_err=$((n_err + 1)) ;;
  esac
done

tested=$((n_pass + n_fail + n_load + n_err))
summary="$n_pass of $tested non-volumetric scenes pass; $n_fail fail the z-test; $n_load do not load; $n_err errors; $n_skip skipped"
echo
echo "$summary"

# Markdown tables ('|' escaped, '<' and '>' as entities: the loader's messages quote XML elements).
md_escape() { local d="$1"; d=${d//|/\\|} d=${d//</\&lt;} d=${d//>/\&gt;}; echo "$d"; }
md="$out/conformance.md"
{
  echo "# Mitsuba 3 render tests: conformance"
  echo
  echo "Made by \`scripts/mitsuba-conformance.sh\` on $(date -u +%Y-%m-%d) from \`$scenes_dir\`"
  if git -C "$repo" rev-parse --short HEAD >/dev/null 2>&1; then
    echo "(renderer commit $(git -C "$repo" rev-parse --short HEAD)$(git -C "$repo" diff --quiet HEAD 2>/dev/null || echo ', with local changes'))."
  fi
  echo
  echo "Each scene is rendered at Mitsuba's budget spp = 2000000 // pixels and z-tested per pixel and XYZ"
  echo "channel against \`refs/<name>_ref_rgb.exr\` with its per-sample variance \`_var.exr\` (floored at 1e-4):"
  echo "a value fails when its two-sided p-value is at most the Sidak level 1 - 0.99^(1/pixels) (family-wise"
  echo "significance 0.01); a scene passes when at least 99.75% of its values pass."
  echo
  echo "$summary."
  echo
  echo "| scene | result | why not |"
  echo "|---|---|---|"
  for r in "${rows[@]}"; do
    IFS=$'\t' read -r s i n st d sh <<<"$r"
    echo "| \`$s\` | $st | $(md_escape "$sh") |"
  done
  echo
  echo "Details (the loader's first error, or the z-test's figures; renders, logs and p-value maps in \`$out\`):"
  echo
  echo "| scene | integrator | spp | result | details |"
  echo "|---|---|---|---|---|"
  for r in "${rows[@]}"; do
    IFS=$'\t' read -r s i n st d sh <<<"$r"
    echo "| \`$s\` | $i | $n | $st | $(md_escape "$d") |"
  done
} >"$md"
echo "table: $md"

rc=0
if [ $strict -eq 1 ] && [ $((n_fail + n_load + n_err)) -gt 0 ]; then
  echo "mitsuba-conformance: --strict: $((n_fail + n_load + n_err)) tested scene(s) do not pass" >&2
  rc=1
fi
if [ -n "$expect" ]; then
  while IFS= read -r line || [ -n "$line" ]; do
    line=${line%%#*}
    line=$(sed -e 's/^[[:space:]]*//' -e 's/[[:space:]]*$//' <<<"$line")
    [ -n "$line" ] || continue
    if [ ! -f "$scenes_dir/$line" ]; then
      echo "mitsuba-conformance: warning: expected scene $line is not in $scenes_dir" >&2
    elif [ -z "${status_of[$line]+x}" ]; then
      [ -n "$only" ] || { echo "mitsuba-conformance: expected scene $line was not run" >&2; rc=1; }
    elif [ "${status_of[$line]}" != pass ]; then
      echo "mitsuba-conformance: expected to pass but ${status_of[$line]}: $line" >&2
      rc=1
    fi
  done <"$expect"
fi
exit $rc
