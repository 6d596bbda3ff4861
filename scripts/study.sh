#!/usr/bin/env bash
# The regularisation study of one scene (issue 16): bias and variance against the sample budget of
# PT and BPT with each regulariser, its consistent schedule against a fixed bandwidth, MSE against
# the bandwidth (a sweep), error against time, and the HTML report that puts them beside the
# images. Default scene: the point light inside the glass sphere (scenes/cornell-box-point-in-glass.xml),
# where plain PT renders nothing and every regulariser is active. Outputs in out/study/<scene>/:
#   ref.exr (+ .json: the reference's command, spp and scene hash), bv/ (biasvar: per configuration
#   and budget the maps, biasvar.json, biasvar.png/.svg), sweep/ (biasvar --sweep: sweep.csv,
#   sweep.png/.svg), conv/ (convergence), report.html.
# Usage: bash scripts/study.sh [SCENE.xml] ; environment: RES (64), REF_TIME (seconds, 180), RUNS (16),
# SPP (4,16,64,256), CROP (the figures' rectangle; default: the room below the sphere at 64^2),
# CONV_TIME (seconds per configuration, 20). Takes about 15 minutes on 2 cores with the defaults.
# See docs/regularisation-study.md for what the figures of the default scene show.
set -euo pipefail
cd "$(dirname "$0")/.."
SCENE=${1:-scenes/cornell-box-point-in-glass.xml}
RES=${RES:-64}
REF_TIME=${REF_TIME:-180}
RUNS=${RUNS:-16}
SPP=${SPP:-4,16,64,256}
CROP=${CROP:-0,46,64,18}
CONV_TIME=${CONV_TIME:-20}
B=${LT_BUILD_DIR:-build}
cmake -S . -B "$B" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$B" --target reference biasvar convergence report >/dev/null
T="$B/tools"
O="out/study/$(basename "$SCENE" .xml)"
mkdir -p "$O"

# The reference: VCM (it samples every path of the room; it lacks only the light seen through the
# glass, which the crop leaves out).
"$T/reference" "$SCENE" -D res="$RES" -c vcm --time "$REF_TIME" --chunks 4 -o "$O/ref.exr"

# Each regulariser with its schedule on and with its bandwidth fixed (PT, which cannot render the
# room's light at all without one), and BPT with each (which can, but not the caustics seen through
# the glass).
CONFIGS=(
  -c "pt --reg jg19 --label PT+JG19"
  -c "pt --reg jg19 --reg-schedule fixed --label PT+JG19-fixed"
  -c "pt --reg kd13 --label PT+KD13"
  -c "pt --reg kd13 --reg-lambda 0 --label PT+KD13-fixed"
  -c "pt --reg opsr --reg-opsr-gamma 0.1 --reg-opsr-consistent --label PT+OPSR"
  -c "pt --reg opsr --reg-opsr-gamma 0.1 --label PT+OPSR-fixed"
  -c "pt --reg jg19,opsr --reg-opsr-gamma 0.1 --label PT+JG19+OPSR"
  -c "bpt --label BPT"
  -c "bpt --reg jg19 --label BPT+JG19"
  -c "bpt --reg kd13 --label BPT+KD13"
  -c "bpt --reg opsr --reg-opsr-gamma 0.1 --label BPT+OPSR"
  -c "vcm --label VCM"
)
"$T/biasvar" "$SCENE" -D res="$RES" -r "$O/ref.exr" --crop "$CROP" "${CONFIGS[@]}" -k "$RUNS" --spp "$SPP" -o "$O/bv"

# MSE against OPSR's gamma and JG19's tau_0 (fixed bandwidths), at each budget.
"$T/biasvar" "$SCENE" -D res="$RES" -r "$O/ref.exr" --crop "$CROP" -c "pt --reg opsr --label PT+OPSR" \
  --sweep reg-opsr-gamma=0.01,0.03,0.1,0.3,1 -k "$RUNS" --spp "$SPP" -o "$O/sweep-opsr"
"$T/biasvar" "$SCENE" -D res="$RES" -r "$O/ref.exr" --crop "$CROP" -c "pt --reg jg19 --reg-schedule fixed --label PT+JG19" \
  --sweep reg-tau=3,10,30,100,300,1000 -k "$RUNS" --spp "$SPP" -o "$O/sweep-jg19"

# Error against time, every configuration.
"$T/convergence" "$SCENE" -D res="$RES" -r "$O/ref.exr" "${CONFIGS[@]}" --time "$CONV_TIME" -o "$O/conv"

"$T/report" --convergence "$O/conv" --biasvar "$O/bv" --biasvar "$O/sweep-opsr" --biasvar "$O/sweep-jg19" \
  --crop "$CROP" -o "$O/report.html"
echo "study: wrote $O/report.html"
