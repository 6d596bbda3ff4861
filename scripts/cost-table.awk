# The markdown table of scripts/cost.sh and scripts/cost-time.sh: reads CSV lines
# "scene,integrator,configuration,ratio" (scenes in the order they first appear) and prints one row
# per scene, one column per integrator (pt, bpt, vcm, or those in `integrators`) and configuration.
#   awk -F, -v title="..." -v configs="jg19-nothing jg19 opsr kd13" [-v integrators="pt"] -f scripts/cost-table.awk FILE
{ r[$1 "," $2 "," $3] = $4; if (!($1 in seen)) { seen[$1] = 1; order[++ns] = $1 } }
END {
  nc = split(configs, c, " ")
  printf "%s\n\n| scene |", title
  ni = split(integrators == "" ? "pt bpt vcm" : integrators, integ, " ")
  for (ii = 1; ii <= ni; ++ii) for (k = 1; k <= nc; ++k) printf " %s %s |", toupper(integ[ii]), c[k]
  printf "\n|---|"
  for (k = 1; k <= ni * nc; ++k) printf "---:|"
  printf "\n"
  for (s = 1; s <= ns; ++s) {
    printf "| %s |", order[s]
    for (ii = 1; ii <= ni; ++ii) for (k = 1; k <= nc; ++k) printf " %.2f |", r[order[s] "," integ[ii] "," c[k]]
    printf "\n"
  }
}
