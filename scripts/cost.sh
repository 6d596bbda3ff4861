#!/usr/bin/env bash
# What a regularised sample costs: the instructions (callgrind) of a sample of PT, BPT and VCM
# with each regulariser over those of the same integrator without one, per scene. A sample's
# count is the difference between renders of 10 and 2 spp over 8, so that what a render pays
# once (start-up, scene and BVH build, writing the image, whose compression depends on its
# content) is left out. An instruction count does not depend on the shared machine's load, so one
# run per configuration is enough; docs/regularisation-cost.md says how it relates to wall time.
#   bash scripts/cost.sh [OUT]      (default out/cost; needs valgrind: bash scripts/setup.sh cost)
# Writes OUT/totals.csv (scene, integrator, configuration, instructions at 2 and at 10 spp) and
# OUT/cost.md (the ratios). Configurations: none; jg19 with --reg-tau 1e30 (the heuristics'
# bookkeeping on every path, nothing regularised: images identical to none); jg19, opsr and kd13
# with their defaults. 13 scenes x 3 integrators x 5 configurations x 2 renders at 48x48, 1 thread
# each: about 6 minutes on 2 cores. COST_CONFIGS, COST_SCENES and COST_INTEGRATORS choose others,
# among the configurations OPSR's reference sets (opsr-low ... opsr-aggressive):
# scripts/cost-common.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
out="${1:-out/cost}"
command -v valgrind >/dev/null || { echo "cost.sh: valgrind not found (bash scripts/setup.sh cost installs it)" >&2; exit 1; }
[ -x build/tools/render ] || { echo "cost.sh: build/tools/render not found (bash scripts/setup.sh build)" >&2; exit 1; }
mkdir -p "$out/runs"

# shellcheck source=scripts/cost-common.sh
source scripts/cost-common.sh

for sc in "${scenes[@]}"; do
  for i in "${integrators[@]}"; do
    for c in "${configs[@]}"; do
      for spp in 2 10; do
        name="$(echo "$sc" | tr / _)-$i-$c-$spp"
        echo "valgrind --tool=callgrind --callgrind-out-file=$out/runs/$name.cg build/tools/render scenes/$sc.xml -D res=48 --spp $spp --threads 1 --seed 1 --integrator $i $(options "$c") -q -o $out/runs/$name.exr"
      done
    done
  done
done | xargs -P "$(nproc)" -I{} sh -c '{} >/dev/null 2>&1 || { echo "cost.sh: failed: {}" >&2; exit 255; }'

count() { awk '/^summary:/ {print $2; exit}' "$out/runs/$1.cg"; }
echo "scene,integrator,configuration,instructions_2spp,instructions_10spp" > "$out/totals.csv"
for sc in "${scenes[@]}"; do
  for i in "${integrators[@]}"; do
    for c in "${configs[@]}"; do
      name="$(echo "$sc" | tr / _)-$i-$c"
      echo "$sc,$i,$c,$(count "$name-2"),$(count "$name-10")" >> "$out/totals.csv"
    done
  done
done
rm -f "$out"/runs/*.cg "$out"/runs/*.exr "$out"/runs/*.png

# The ratios (each configuration's count over none's), as the table.
awk -F, 'NR == 1 { next }
  { n[$1 "," $2 "," $3] = $5 - $4; if ($3 != "none") key[++nk] = $1 "," $2 "," $3 }
  END { for (i = 1; i <= nk; ++i) { split(key[i], f, ","); print key[i] "," n[key[i]] / n[f[1] "," f[2] ",none"] } }' \
  "$out/totals.csv" |
  awk -F, -v configs="${configs[*]:1}" -v integrators="${integrators[*]}" -f scripts/cost-table.awk \
    -v title="Instructions per sample over those of the same integrator without a regulariser (48x48, 1 thread, seed 1; renders of 10 and 2 spp, their difference)." \
    > "$out/cost.md"
cat "$out/cost.md"
