#!/usr/bin/env bash
# The least a regularised path-tracer sample can cost on the SDS scenes, beside what JG19's and
# OPSR's cost (docs/regularisation-cost.md, "The floor").
#
# On these scenes a regulariser makes next-event connections that unregularised sampling cannot
# make at all (at smooth glass and mirror vertices), so its sample does more work than the
# unregularised one however little the regulariser itself costs. The floor measures that work
# alone: a throw-away build (scripts/cost-floor.patch, applied to a temporary worktree of HEAD; it
# never enters the project) whose unregularised path tracer also makes those connections, with
# LT_FLOOR=all at every smooth vertex (the connections JG19's path tracer makes) and with
# LT_FLOOR=after-rough at the smooth vertices after a non-smooth one on the camera walk (OPSR's),
# each evaluated as a rough lobe (one value-only evaluation, as the regularisers' own) and
# weighted 1 (no MIS). No heuristic, no per-vertex state, no per-technique densities: a plain
# connection's work for each of the regulariser's connections.
# The check that it makes exactly the regulariser's connections: the rays it casts equal JG19's
# (all) and OPSR's (after-rough), both casting every connection (--reg-tail-rr 0: jg19-all,
# opsr-all), counted on one render per scene (48x48, 8 spp, 1 thread); the table says "equal" or
# "DIFFER". Beside them the regularisers with their defaults, whose tail roulette (regularizer.h
# (9)) casts fewer: the floor is that of a regulariser casting every connection.
#
#   bash scripts/cost-floor.sh [OUT] [ROUNDS]   (default out/cost-floor, 11 rounds; ~8 minutes)
#
# Time as scripts/cost-time.sh measures it (the render loop's seconds, 128x128, 2 threads, seed 1,
# PT 48 spp), in rounds: none, none with the patched binary (the patch alone should cost nothing),
# floor all, jg19-all, jg19, floor after-rough, opsr-all, opsr, one after the other; each ratio is taken within its
# round and the table gives the median over the rounds. Writes OUT/rounds.csv and OUT/cost-floor.md.
# Needs build/tools/render (bash scripts/setup.sh build) and git (the worktree of HEAD).
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-out/cost-floor}"
rounds="${2:-11}"
[ -x build/tools/render ] || { echo "cost-floor.sh: build/tools/render not found (bash scripts/setup.sh build)" >&2; exit 1; }
mkdir -p "$out/runs"

work="$(mktemp -d)"
cleanup() {
  git worktree remove --force "$work/tree" >/dev/null 2>&1 || true
  rm -rf "$work"
}
trap cleanup EXIT
git worktree add -q --detach "$work/tree" HEAD
git -C "$work/tree" apply "$PWD/scripts/cost-floor.patch" ||
  { echo "cost-floor.sh: scripts/cost-floor.patch no longer applies to HEAD" >&2; exit 1; }
cmake -S "$work/tree" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$work/build" --target render >/dev/null
plain=build/tools/render
patched="$work/build/tools/render"

scenes=(cornell-box-point-in-glass hard/amber hard/caustic-mirror hard/caustic-point-glass hard/specular-point-view)
configs=(none none-patched floor-all jg19-all jg19 floor-after-rough opsr-all opsr)
run() {  # run CONFIG SCENE JSON ARGS...
  local c="$1" sc="$2" json="$3" bin="$plain"
  local -a vars=()
  shift 3
  case "$c" in
    none) ;;
    none-patched) bin="$patched" ;;
    floor-all) bin="$patched" vars=(LT_FLOOR=all) ;;
    floor-after-rough) bin="$patched" vars=(LT_FLOOR=after-rough) ;;
    jg19-all | opsr-all) set -- "$@" --reg "${c%-all}" --reg-tail-rr 0 ;;
    *) set -- "$@" --reg "$c" ;;
  esac
  env "${vars[@]}" "$bin" "scenes/$sc.xml" "$@" -q -o "$out/runs/run.exr" --stats-json "$json" >/dev/null 2>&1 ||
    { echo "cost-floor.sh: failed: $sc $c" >&2; exit 1; }
}
value() { sed -n "s/.*\"$1\": \\([0-9.e+-]*\\).*/\\1/p" "$2"; }

# The rays check.
declare -A rays
for sc in "${scenes[@]}"; do
  for c in floor-all jg19-all floor-after-rough opsr-all; do
    run "$c" "$sc" "$out/runs/rays.json" -D res=48 --spp 8 --threads 1 --seed 1 --integrator pt
    rays[$sc,$c]=$(value rays "$out/runs/rays.json")
  done
done

echo "scene,configuration,round,seconds,ratio" > "$out/rounds.csv"
for sc in "${scenes[@]}"; do
  for ((r = 1; r <= rounds; ++r)); do
    base=""
    for c in "${configs[@]}"; do
      run "$c" "$sc" "$out/runs/run.json" -D res=128 --spp 48 --threads 2 --seed 1 --integrator pt
      s=$(value seconds "$out/runs/run.json")
      [ "$c" = none ] && base="$s"
      echo "$sc,$c,$r,$s,$(awk -v a="$s" -v b="$base" 'BEGIN { printf "%.4f", a / b }')" >> "$out/rounds.csv"
    done
  done
done
rm -f "$out"/runs/run.* "$out"/runs/rays.json 2>/dev/null || true

{
  echo "Path tracer, render-loop seconds per sample over plain PT's (128x128, 2 threads, seed 1, 48 spp; median of $rounds rounds)."
  echo "floor all: the connections JG19 makes, at a plain connection's cost; floor after-rough: OPSR's."
  echo "jg19 all, opsr all: the regularisers casting every connection (--reg-tail-rr 0), as the floors do; jg19, opsr: their defaults (the tail roulette at 0.1)."
  echo
  echo "| scene | rays: floor all = jg19 all, after-rough = opsr all | none, patched binary | floor all | jg19 all | jg19 | floor after-rough | opsr all | opsr |"
  echo "|---|---|---:|---:|---:|---:|---:|---:|---:|"
  for sc in "${scenes[@]}"; do
    check() { [ "${rays[$sc,$1]}" = "${rays[$sc,$2]}" ] && echo "equal (${rays[$sc,$1]})" || echo "DIFFER (${rays[$sc,$1]} vs ${rays[$sc,$2]})"; }
    row="| $sc | $(check floor-all jg19-all); $(check floor-after-rough opsr-all) |"
    for c in "${configs[@]:1}"; do
      m=$(awk -F, -v sc="$sc" -v c="$c" '$1 == sc && $2 == c { a[++n] = $5 }
        END { for (i = 2; i <= n; ++i) for (j = i; j > 1 && a[j - 1] > a[j]; --j) { t = a[j]; a[j] = a[j - 1]; a[j - 1] = t }
              printf "%.2f", n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2 }' "$out/rounds.csv")
      row="$row $m |"
    done
    echo "$row"
  done
} > "$out/cost-floor.md"
cat "$out/cost-floor.md"
