#!/usr/bin/env bash
# Fuzzes the scene and mesh loaders with libFuzzer (issue 17; tests/fuzz/README.md).
#   scripts/fuzz.sh [SECONDS] [TARGET ...]     TARGET: scene obj ply serialized (default: all)
# Builds the targets with clang, ASan and UBSan in build-fuzz/ (the ordinary build is untouched),
# seeds build-fuzz/corpus/TARGET from scenes/ and tests/data (tests/fuzz/make_seeds.py) and runs
# each target for SECONDS (default 1800: 30 CPU minutes), two at a time. Findings are written to
# build-fuzz/findings/TARGET/ (crash-*, leak-*, timeout-*, oom-*); the log of each run to
# build-fuzz/TARGET.log. A finding, once fixed, goes to tests/fuzz/regressions/TARGET/, where
# ctest replays it (test_fuzz_regressions).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
secs="${1:-1800}"
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(scene obj ply serialized)
out="${FUZZ_BUILD:-$here/build-fuzz}"

command -v clang++ >/dev/null || { echo "fuzz.sh: clang++ not found (apt install clang libclang-rt-14-dev)" >&2; exit 1; }
CC=clang CXX=clang++ cmake -S "$here" -B "$out" -G Ninja -DLT_FUZZ=ON -DBUILD_TESTING=OFF >/dev/null
ninja -C "$out" $(printf 'fuzz_%s ' "${targets[@]}") >/dev/null
rm -rf "$out/seeds" && python3 "$here/tests/fuzz/make_seeds.py" "$here" "$out/seeds"

run() {
    local t="$1" dict=() maxlen=4096
    [ -f "$here/tests/fuzz/$t.dict" ] && dict=(-dict="$here/tests/fuzz/$t.dict")
    [ "$t" = scene ] && maxlen=16384
    mkdir -p "$out/corpus/$t" "$out/findings/$t"
    # -malloc_limit_mb: a single allocation over 512 MB is a finding (an input of a few KB must
    # not make the loader allocate that much: a declared size has to be checked first).
    "$out/tests/fuzz/fuzz_$t" "$out/corpus/$t" "$out/seeds/$t" "${dict[@]}" \
        -max_total_time="$secs" -max_len="$maxlen" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=512 \
        -fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
        -artifact_prefix="$out/findings/$t/" -print_final_stats=1 >"$out/$t.log" 2>&1 || true
    # fork mode (a finding does not end the run): the last status line has the executions, the
    # coverage (cov: edges, ft: features), the corpus and the counts of ooms, timeouts and crashes
    echo "$t: $(grep -E '^#[0-9]+: cov:' "$out/$t.log" | tail -1)"
    echo "$t: findings: $(ls "$out/findings/$t" | wc -l)"
}

running=0
for t in "${targets[@]}"; do
    run "$t" &
    running=$((running + 1))
    if [ $running -ge 2 ]; then wait -n; running=$((running - 1)); fi
done
wait
