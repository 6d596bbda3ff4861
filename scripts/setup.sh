#!/usr/bin/env bash
# One script for a fresh Debian 12 machine: installs every dependency from Debian packages,
# builds in Release, then either renders the default scene or runs the test suite.
#   bash scripts/setup.sh render   -> out/cornell-box.exr and out/cornell-box.png
#   bash scripts/setup.sh test     -> the whole ctest suite
#   bash scripts/setup.sh build    -> only install and build
#   bash scripts/setup.sh cost     -> also valgrind: what a regularised sample costs
#                                     (scripts/cost.sh, docs/regularisation-cost.md)
#   bash scripts/setup.sh fuzz [SECONDS]
#                                  -> also clang and its fuzzer runtime: fuzzes the loaders
#                                     (scripts/fuzz.sh, tests/fuzz/README.md; 30 min each by default)
set -euo pipefail
cd "$(dirname "$0")/.."
action="${1:-render}"

PACKAGES=(build-essential cmake ninja-build pkg-config
  libembree-dev libopenexr-dev libglm-dev libtbb-dev catch2 libcli11-dev libpugixml-dev
  libtinyobjloader-dev libstb-dev nlohmann-json3-dev libfmt-dev zlib1g-dev gnuplot-nox
  libopenmpi-dev openmpi-bin)
[ "$action" = fuzz ] && PACKAGES+=(clang libclang-rt-14-dev python3)
[ "$action" = cost ] && PACKAGES+=(valgrind)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  echo "setup: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}"
fi

jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$jobs"

case "$action" in
  render)
    ./build/tools/render scenes/cornell-box.xml -o out/cornell-box.exr
    ;;
  test)
    ctest --test-dir build -j "$jobs" --output-on-failure --timeout 600
    ;;
  build) ;;
  cost)
    scripts/cost.sh
    ;;
  fuzz)
    scripts/fuzz.sh "${2:-1800}"
    ;;
  *) echo "usage: scripts/setup.sh [render|test|build|cost|fuzz [SECONDS]]" >&2; exit 1 ;;
esac
