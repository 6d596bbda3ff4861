#!/usr/bin/env bash
# Renders the reference of the S-D-S consistency test (tests/data/sds/reference.exr) once:
# VCM, 24x24, 32768 iterations (the radius has shrunk by 32768^-0.125 = 0.27 by then).
# Run after building; the result is committed (about 7 KB).
set -euo pipefail
cd "$(dirname "$0")/.."
./build/tools/render tests/data/sds/sds.xml --integrator vcm -D res=24 --spp 32768 --seed 7919 --quiet \
  -o tests/data/sds/reference.exr --stats-json tests/data/sds/reference.json
