#!/usr/bin/env bash
# Equal-time benchmark of every available integrator on scenes/hard/*.xml and
# scenes/cornell-box*.xml; writes BENCHMARKS.md (machine, time, spp, samples/s, relMSE, RMS-RE,
# MAPE). References are cached under out/bench/refs/. Default run: 64x64, 3 s per render, 20 s per
# reference (about 5-10 minutes on 2 cores). Extra arguments go to the bench tool, e.g.
#   bash scripts/bench.sh --time 5 --res 128 --integrators pt,bpt
# See docs/tools.md.
set -euo pipefail
cd "$(dirname "$0")/.."
B=${LT_BUILD_DIR:-build}
cmake -S . -B "$B" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$B" --target bench reference >/dev/null
exec "$B/tools/bench" "$@"
