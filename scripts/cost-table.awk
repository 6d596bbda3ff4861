# The markdown table of scripts/cost.sh and scripts/cost-time.sh: reads CSV lines
# "scene,integrator,configuration,ratio" (scenes in the order they first appear) and prints one row
# per scene, one column per integrator (pt, bpt, vcm) and configuration.
#   awk -F, -v title="..." -v configs="jg19-nothing jg19 opsr kd13" -f scripts/cost-table.awk FILE
{ r[$1 "," $2 "," $3] = $4; if (!($1 in seen)) { seen[$1] = 1; order[++ns] = $1 } }
END {
  nc = split(configs, c, " ")
  printf "%s\n\n| scene |", title
  split("PT BPT VCM", label, " ")
  for (ii = 1; ii <= 3; ++ii) for (k = 1; k <= nc; ++k) printf " %s %s |", label[ii], c[k]
  printf "\n|---|"
  for (k = 1; k <= 3 * nc; ++k) printf "---:|"
  printf "\n"
  split("pt bpt vcm", integ, " ")
  for (s = 1; s <= ns; ++s) {
    printf "| %s |", order[s]
    for (ii = 1; ii <= 3; ++ii) for (k = 1; k <= nc; ++k) printf " %.2f |", r[order[s] "," integ[ii] "," c[k]]
    printf "\n"
  }
}
