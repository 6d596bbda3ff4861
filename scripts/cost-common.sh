# shellcheck shell=bash
# What scripts/cost.sh and scripts/cost-time.sh measure: the scenes, the configurations (none
# first: the others are divided by it) and each configuration's render options.
# jg19-nothing: JG19 with a bound that changes nothing (its bookkeeping on every path, images
# identical to none); the others with their defaults.
# shellcheck disable=SC2034  # (read by the scripts that source this file)
scenes=(cornell-box cornell-box-ggx cornell-box-glass-sphere cornell-box-mirror-sphere cornell-box-point-in-glass
  hard/amber hard/caustic-mirror hard/caustic-point-glass hard/caustic-roughness hard/glass-ball-body
  hard/glossy-chains hard/glossy-ring hard/specular-point-view)
# shellcheck disable=SC2034
configs=(none jg19-nothing jg19 opsr kd13)
options() {
  case "$1" in
    jg19-nothing) echo "--reg jg19 --reg-tau 1e30" ;;
    *) echo "--reg $1" ;;
  esac
}
