#!/usr/bin/env bash
# The main job: builds libimap and the C examples with CMake and runs the Cornell box to
# 1 % estimated error (or 60 s), printing its error-against-time table and vertex values.
# Arguments are passed on: demo.sh [target_error] [time_budget_s] [bands].
set -euo pipefail
cd "$(dirname "$0")/.."
EMBREE_DIR=$(scripts/setup-embree.sh)
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DIMAP_EMBREE_DIR="$EMBREE_DIR" >/dev/null
cmake --build build -j "$(nproc)" >/dev/null
exec build/c_examples/cornell_box "${1:-0.01}" "${2:-60}" "${3:-3}"
