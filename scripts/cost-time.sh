#!/usr/bin/env bash
# What a regularised sample costs in time: the render loop's seconds (--stats-json "seconds": no
# scene load, no image write) of PT, BPT and VCM with each regulariser over those of the same
# integrator without one, per scene, on the same scenes and configurations as scripts/cost.sh
# (which counts instructions). The machine may be shared, so the configurations run in rounds:
# each round renders none, jg19-nothing, jg19, opsr and kd13 one after the other, a ratio is taken
# within its round, and the table gives the median over the rounds (min-max in OUT/rounds.csv),
# followed by the cells over and under 1.15 in at least 6/7 of the rounds.
#   bash scripts/cost-time.sh [OUT] [ROUNDS]   (default out/cost-time, 7 rounds)
# 128x128, 2 threads, seed 1; 48 spp for PT, 16 for BPT and VCM (0.1-1 s a render; COST_SPP_SCALE=K
# renders K times as many, for a finer ratio on a busy machine: a render of 0.1 s is dominated by
# its start and the threads' scheduling). Writes
# OUT/rounds.csv (scene, integrator, configuration, round, seconds, ratio to that round's none)
# and OUT/cost-time.md. About 10 minutes with 7 rounds. COST_CONFIGS, COST_SCENES and
# COST_INTEGRATORS choose other configurations, scenes and integrators (scripts/cost-common.sh; set
# them for ROUNDS 0 too).
# ROUNDS 0: no renders, only the table from an existing OUT/rounds.csv (e.g. the rounds of two runs
# appended into one file: the tables' medians then cover both).
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-out/cost-time}"
rounds="${2:-7}"
if [ "$rounds" = 0 ]; then
  [ -s "$out/rounds.csv" ] || { echo "cost-time.sh: ROUNDS 0 needs $out/rounds.csv" >&2; exit 1; }
else
  [ -x build/tools/render ] || { echo "cost-time.sh: build/tools/render not found (bash scripts/setup.sh build)" >&2; exit 1; }
  mkdir -p "$out/runs"
fi

# shellcheck source=scripts/cost-common.sh
source scripts/cost-common.sh
scale="${COST_SPP_SCALE:-1}"
[[ "$scale" =~ ^[1-9][0-9]*$ ]] || { echo "COST_SPP_SCALE must be a positive integer, got '$scale'" >&2; exit 1; }
sppOf() { [ "$1" = pt ] && echo $((48 * scale)) || echo $((16 * scale)); }
seconds() { sed -n 's/.*"seconds": \([0-9.e+-]*\).*/\1/p' "$1"; }

[ "$rounds" = 0 ] || echo "scene,integrator,configuration,round,seconds,ratio" > "$out/rounds.csv"
for sc in "${scenes[@]}"; do
  for i in "${integrators[@]}"; do
    for ((r = 1; r <= rounds; ++r)); do
      base=""
      for c in "${configs[@]}"; do
        json="$out/runs/run.json"
        # shellcheck disable=SC2046
        build/tools/render "scenes/$sc.xml" -D res=128 --spp "$(sppOf "$i")" --threads 2 --seed 1 --integrator "$i" \
          $(options "$c") -q -o "$out/runs/run.exr" --stats-json "$json" >/dev/null 2>&1 ||
          { echo "cost-time.sh: failed: $sc $i $c" >&2; exit 1; }
        s=$(seconds "$json")
        [ "$c" = none ] && base="$s"
        echo "$sc,$i,$c,$r,$s,$(awk -v a="$s" -v b="$base" 'BEGIN { printf "%.4f", a / b }')" >> "$out/rounds.csv"
      done
    done
  done
done
rm -f "$out"/runs/run.* 2>/dev/null || true

# The median ratio over the rounds of each configuration, as the table.
awk -F, 'NR > 1 && $3 != "none" {
    key = $1 "," $2 "," $3; v[key, ++cnt[key]] = $6; if (!(key in seen)) { seen[key] = 1; order[++nk] = key }
  }
  function median(key,   n, i, j, t, a) {
    n = cnt[key]
    for (i = 1; i <= n; ++i) a[i] = v[key, i]
    for (i = 2; i <= n; ++i) for (j = i; j > 1 && a[j - 1] > a[j]; --j) { t = a[j]; a[j] = a[j - 1]; a[j - 1] = t }
    return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
  }
  END { for (i = 1; i <= nk; ++i) print order[i] "," median(order[i]) }' "$out/rounds.csv" |
  awk -F, -v configs="${configs[*]:1}" -v integrators="${integrators[*]}" -f scripts/cost-table.awk \
    -v title="Render-loop seconds per sample over those of the same integrator without a regulariser (128x128, 2 threads, seed 1; PT $(sppOf pt) spp, BPT and VCM $(sppOf bpt); the median over rounds of the ratio within a round)." \
    > "$out/cost-time.md"
# Against the issues' 1.15: a cell is over (under) when at least 6/7 of its rounds are (its
# (k+1)-th lowest, or highest, round, k = floor(n / 7) of n rounds); the others are on the line.
# (The rounds of a cell spread by about 0.08, median over the cells, so one run's median can sit
# on either side of 1.15.)
awk -F, -v limit=1.15 'NR > 1 && $3 != "none" {
    key = $1 " " $2 " " $3; v[key, ++cnt[key]] = $6; if (!(key in seen)) { seen[key] = 1; order[++nk] = key }
  }
  END {
    for (i = 1; i <= nk; ++i) {
      key = order[i]; n = cnt[key]
      for (j = 1; j <= n; ++j) a[j] = v[key, j]
      for (j = 2; j <= n; ++j) for (k = j; k > 1 && a[k - 1] > a[k]; --k) { t = a[k]; a[k] = a[k - 1]; a[k - 1] = t }
      k = int(n / 7); lo = a[k + 1]; hi = a[n - k]
      if (lo > limit) { ++over; list = list (list == "" ? "" : ", ") key }
      else if (hi <= limit) ++under
      else ++line
    }
    printf "\nAgainst %.2f, in at least 6/7 of the rounds: %d cells over, %d under, %d on the line.\n", limit, over, under, line
    printf "Over: %s.\n", list
  }' "$out/rounds.csv" >> "$out/cost-time.md"
cat "$out/cost-time.md"
