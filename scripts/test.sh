#!/usr/bin/env bash
# test.sh: install what is missing, build, and run the whole test suite with ctest:
#   1. the default build (AVX2 paths compiled, chosen at run time), all tests;
#   2. the scalar-only build (-DOBS_ENABLE_SIMD=OFF), all tests but the process-level ones
#      (label "process": flags, files, exit codes; they do not depend on the instruction set);
#   3. the sanitizer build (CMakePresets.json "asan": clang-14, ASan + UBSan, -O1 -g), all tests;
#      any sanitizer report fails its test (suppressions: tests/sanitizers/, docs/reliability.md);
#   4. the fuzz build ("fuzz" preset: libFuzzer + ASan + UBSan): each fuzz target runs for
#      FUZZ_SECONDS (default 30) from the committed corpus; a crash, leak or broken invariant
#      fails (tests/fuzz/run.sh).
# OBS_TEST_STAGES (default "1 2 3 4") picks stages.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
"$here/scripts/setup.sh"
jobs="$(nproc)"
stages="${OBS_TEST_STAGES:-1 2 3 4}"
sup="$here/tests/sanitizers"
stage() { case " $stages " in *" $1 "*) return 0 ;; *) return 1 ;; esac; }
if stage 1; then
  echo "== default build (SIMD on) =="
  "$here/scripts/build.sh" "$here/build"
  ctest --test-dir "$here/build" --output-on-failure -j"$jobs"
fi
if stage 2; then
  echo "== scalar-only build (OBS_ENABLE_SIMD=OFF) =="
  "$here/scripts/build.sh" "$here/build-scalar" -DOBS_ENABLE_SIMD=OFF
  # Every test but the process-level ones (label "process", tests/CMakeLists.txt): those check the
  # command's flags, files and exit codes, which do not depend on the instruction set, and run in
  # stages 1 and 3.
  ctest --test-dir "$here/build-scalar" --output-on-failure -j"$jobs" -LE process
fi
if stage 3; then
  echo "== sanitizer build (clang-14, ASan + UBSan) =="
  (cd "$here" && cmake --preset asan >/dev/null && cmake --build --preset asan -j"$jobs")
  ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:suppressions=$sup/asan.supp" \
  LSAN_OPTIONS="suppressions=$sup/lsan.supp" \
  UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$sup/ubsan.supp" \
    ctest --test-dir "$here/build-asan" --output-on-failure -j"$jobs"
fi
if stage 4; then
  echo "== fuzz build (libFuzzer, ASan + UBSan): ${FUZZ_SECONDS:-30} s per target =="
  (cd "$here" && cmake --preset fuzz >/dev/null && cmake --build --preset fuzz -j"$jobs")
  "$here/tests/fuzz/run.sh" "$here/build-fuzz" "${FUZZ_SECONDS:-30}"
fi
