#!/bin/sh
# Builds embree_bench (needs: apt-get install -y libembree-dev g++). Output: $OUT/embree_bench,
# default target/embree_bench/ under the current folder.
# -ffp-contract=off keeps the camera and AO-direction arithmetic unfused, as in penumbra's Rust,
# so both programs trace bit-identical rays; Embree itself is Debian's prebuilt library.
set -e
OUT=${OUT:-target/embree_bench}
mkdir -p "$OUT"
test -f /usr/include/embree3/rtcore.h || { echo "missing embree3/rtcore.h: apt-get install -y libembree-dev" >&2; exit 1; }
g++ -std=c++17 -O3 -march=native -ffp-contract=off -Wall -Wextra -Wno-unused-parameter \
    "$(dirname "$0")/embree_bench.cpp" -o "$OUT/embree_bench" -lembree3 -pthread
echo "$OUT/embree_bench"
