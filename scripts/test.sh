#!/usr/bin/env bash
# test.sh: install what is missing, build, and run the whole test suite with ctest:
#   1. the default build (AVX2 paths compiled, chosen at run time), all tests;
#   2. the scalar-only build (-DOBS_ENABLE_SIMD=OFF), all tests.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
"$here/scripts/setup.sh"
jobs="$(nproc)"
echo "== default build (SIMD on) =="
"$here/scripts/build.sh" "$here/build"
ctest --test-dir "$here/build" --output-on-failure -j"$jobs"
echo "== scalar-only build (OBS_ENABLE_SIMD=OFF) =="
"$here/scripts/build.sh" "$here/build-scalar" -DOBS_ENABLE_SIMD=OFF
ctest --test-dir "$here/build-scalar" --output-on-failure -j"$jobs"
