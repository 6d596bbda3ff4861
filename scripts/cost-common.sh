# shellcheck shell=bash
# What scripts/cost.sh and scripts/cost-time.sh measure: the scenes, the configurations (none
# first: the others are divided by it) and each configuration's render options.
# jg19-nothing: JG19 with a bound that changes nothing (its bookkeeping on every path, images
# identical to none); opsr-SET: OPSR with the set SET of the reference attenuation file
# (OPSR_TABLE, by default ../shared/data/opsr/opsr-reference-attenuation.json beside the
# project; loaded by path, never copied); the others with their defaults.
# COST_SCENES, COST_CONFIGS and COST_INTEGRATORS (space-separated) choose others, e.g.
#   COST_CONFIGS="none opsr opsr-low opsr-moderate opsr-strong opsr-aggressive" bash scripts/cost.sh out/cost-sets
#   COST_INTEGRATORS=pt (the path tracer only: the OPSR issue's own benchmark)
# shellcheck disable=SC2034  # (read by the scripts that source this file)
read -r -a scenes <<< "${COST_SCENES:-cornell-box cornell-box-ggx cornell-box-glass-sphere cornell-box-mirror-sphere \
cornell-box-point-in-glass hard/amber hard/caustic-mirror hard/caustic-point-glass hard/caustic-roughness \
hard/glass-ball-body hard/glossy-chains hard/glossy-ring hard/specular-point-view}"
read -r -a configs <<< "${COST_CONFIGS:-none jg19-nothing jg19 opsr kd13}"
read -r -a integrators <<< "${COST_INTEGRATORS:-pt bpt vcm}"
for i in "${integrators[@]}"; do
  case "$i" in pt | bpt | vcm) ;; *) echo "COST_INTEGRATORS: '$i' is not pt, bpt or vcm" >&2; exit 1 ;; esac
done
[ "${configs[0]}" = none ] || { echo "COST_CONFIGS must start with none (the others are divided by it)" >&2; exit 1; }
for sc in "${scenes[@]}"; do
  [ -f "scenes/$sc.xml" ] || { echo "COST_SCENES: no scene scenes/$sc.xml" >&2; exit 1; }
done
opsrTable="${OPSR_TABLE:-../shared/data/opsr/opsr-reference-attenuation.json}"
for c in "${configs[@]}"; do
  case "$c" in
    opsr-*) [ -f "$opsrTable" ] || { echo "$c: no OPSR attenuation file at $opsrTable (set OPSR_TABLE)" >&2; exit 1; } ;;
  esac
done
options() {
  case "$1" in
    jg19-nothing) echo "--reg jg19 --reg-tau 1e30" ;;
    opsr-*) echo "--reg opsr --reg-opsr-table $opsrTable:${1#opsr-}" ;;
    *) echo "--reg $1" ;;
  esac
}
