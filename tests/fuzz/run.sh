#!/usr/bin/env bash
# run.sh BUILD_DIR [SECONDS] [TARGET...]: run each libFuzzer target of an OBS_FUZZ=ON build for a
# bounded time (SECONDS, default $FUZZ_SECONDS or 30) and fail on any finding.
#
# Each target starts from the committed seed corpus and regression reproducers (read-only here)
# plus a scratch corpus in BUILD_DIR/fuzz-run/<target>/corpus, where libFuzzer keeps what it
# finds (merge it back with -merge=1 when it is worth committing, docs/reliability.md).
# A crash, a leak, a sanitizer report, a broken invariant, a timeout (25 s per input) or an
# out-of-memory (2 GiB) writes the reproducer to BUILD_DIR/fuzz-run/<target>/artifacts/ and fails
# the run. Logs: BUILD_DIR/fuzz-run/<target>/log; the final stats line is printed per target.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
build="$(cd "${1:?usage: run.sh BUILD_DIR [SECONDS] [TARGET...]}" && pwd)"
secs="${2:-${FUZZ_SECONDS:-30}}"
shift $(( $# >= 2 ? 2 : 1 ))
targets=("$@")
[ "${#targets[@]}" -gt 0 ] || targets=(gltf exr off cli_args json gbuffer render_settings)

sup="$(cd "$here/../sanitizers" && pwd)"
asan="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}:suppressions=$sup/asan.supp"
export LSAN_OPTIONS="suppressions=$sup/lsan.supp"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}:suppressions=$sup/ubsan.supp"
# The targets run FUZZ_JOBS at a time (default: the number of CPUs; each libFuzzer process is
# single-threaded), so CI's 2 cores fuzz two targets at once; each still gets its full SECONDS.
# Their reports are printed in the list's order once all have finished.
jobs="${FUZZ_JOBS:-$(nproc)}"
run_one() {
  local t="$1" bin="$build/tests/fuzz/fuzz_$1" work="$build/fuzz-run/$1"
  mkdir -p "$work/corpus" "$work/artifacts"
  local args=(-max_total_time="$secs" -timeout=25 -rss_limit_mb=2048 -print_final_stats=1
              -artifact_prefix="$work/artifacts/")
  [ -f "$here/dict/$t.dict" ] && args+=(-dict="$here/dict/$t.dict")
  [ "$t" = cli_args ] && args+=(-close_fd_mask=3)
  local dirs=("$work/corpus" "$here/corpus/$t")
  [ -d "$here/regressions/$t" ] && dirs+=("$here/regressions/$t")
  local opts="$asan"
  [ "$t" = exr ] && opts="$opts:fast_unwind_on_malloc=0"
  local rc=0
  ASAN_OPTIONS="$opts" "$bin" "${args[@]}" "${dirs[@]}" >"$work/log" 2>&1 || rc=$?
  echo "$rc" >"$work/rc"
}
for t in "${targets[@]}"; do
  bin="$build/tests/fuzz/fuzz_$t"
  [ -x "$bin" ] || { echo "fuzz: $bin is missing (configure with -DOBS_FUZZ=ON, build obscura_fuzzers)"; exit 2; }
  rm -f "$build/fuzz-run/$t/rc"
done
echo "== ${#targets[@]} fuzz targets, ${secs} s each, ${jobs} at a time =="
running=0
for t in "${targets[@]}"; do
  if [ "$running" -ge "$jobs" ]; then wait -n || true; running=$((running - 1)); fi
  run_one "$t" &
  running=$((running + 1))
done
wait || true
status=0
for t in "${targets[@]}"; do
  work="$build/fuzz-run/$t"
  echo "== fuzz_$t: ${secs} s =="
  rc="$(cat "$work/rc" 2>/dev/null || echo 99)"
  grep -E "^(#[0-9]+ +DONE|stat::number_of_executed_units|stat::peak_rss_mb)" "$work/log" | tr '\n' ' ' || true
  grep -E "^#[0-9]+ +DONE" "$work/log" >/dev/null || tail -n 3 "$work/log" | grep -E "cov:" | tail -n 1 || true
  echo
  if [ "$rc" -ne 0 ]; then
    echo "fuzz_$t FAILED (exit $rc): see $work/log and $work/artifacts/"
    grep -E "ERROR|SUMMARY|invariant broken|Test unit written" "$work/log" | head -n 20 || true
    status=1
  fi
done
exit "$status"
