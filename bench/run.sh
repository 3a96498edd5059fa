#!/usr/bin/env bash
# bench/run.sh: obscura's benchmarks, one command. Builds Release if needed, then runs
#   gbuffer: obscura_bench gbuffer on the bunny and the dragon at 1920x1080 and 1280x720 with 1 and
#            2 threads (median of 20 timed frames after 5 warm-up frames per run);
#   ao:      obscura_bench ao for every registered AO method, its reference blur off and on, on the
#            bunny (the llvmpipe peer's framing) at 1920x1080 and 1280x720 with 1 and 2 threads
#            (median of 9 timed runs after 2 warm-up runs per run), plus SAO as the peer's `sao`
#            stage (level 0 only, no blur);
# REPS interleaved repetitions (default 5) of each. Prints RESULT lines and writes
# bench/results/{gbuffer,ao}.txt; the tables in docs/performance.md are the medians over
# repetitions of each run's median, which this script prints at the end.
# Usage: bench/run.sh [gbuffer|ao|all] [--quick]
#   (REPS=... THREADS="1 2" SIZES="1920x1080 1280x720" METHODS="sao gtao" override)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${BUILD:-$here/build}"
if [ ! -x "$build/obscura_bench" ]; then "$here/scripts/build.sh" "$build"; fi
what="all"; quick=0
for a in "$@"; do
  case "$a" in gbuffer|ao|all) what="$a" ;; --quick) quick=1 ;; *) echo "usage: bench/run.sh [gbuffer|ao|all] [--quick]" >&2; exit 2 ;; esac
done
reps="${REPS:-5}"; threads="${THREADS:-1 2}"; sizes="${SIZES:-1920x1080 1280x720}"; frames=20; aoreps=9
if [ "$quick" = 1 ]; then reps=1; sizes="640x360"; frames=3; aoreps=3; fi
mkdir -p "$here/bench/results"
header() { echo "# $(date -u +%Y-%m-%dT%H:%MZ) $(uname -m) $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs) nproc=$(nproc)"; }

if [ "$what" != ao ]; then
  out="$here/bench/results/gbuffer.txt"
  {
    header
    for r in $(seq 1 "$reps"); do
      for mesh in bunny dragon; do
        for s in $sizes; do
          for t in $threads; do
            for o in peer all; do
              "$build/obscura_bench" gbuffer "$build/data/$mesh.glb" --size "$s" --threads "$t" \
                --reps "$frames" --warmup 5 --outputs "$o" | sed "s/^RESULT/RESULT rep=$r/"
            done
          done
        done
      done
    done
  } | tee "$out"
  python3 - "$out" <<'PY' || true
import sys, re, statistics, collections
rows = collections.defaultdict(list)
for line in open(sys.argv[1]):
    if not line.startswith("RESULT"): continue
    kv = dict(re.findall(r"(\w+)=(\S+)", line))
    key = (kv["mesh"].split("/")[-1], kv["size"], kv["threads"], kv["outputs"])
    rows[key].append((float(kv["median_ms"]), float(kv["coverage"]), float(kv["setup_ms"])))
print("| mesh | size | threads | outputs | median ms | setup ms | coverage |")
print("|---|---|---|---|---|---|---|")
for k in sorted(rows):
    v = rows[k]
    print(f"| {k[0]} | {k[1]} | {k[2]} | {k[3]} | {statistics.median(x[0] for x in v):.2f} | {statistics.median(x[2] for x in v):.2f} | {v[0][1]:.3f} |")
PY
fi

if [ "$what" != gbuffer ]; then
  out="$here/bench/results/ao.txt"
  methods="${METHODS:-$("$build/obscura_bench" methods | xargs)}"
  {
    header
    for r in $(seq 1 "$reps"); do
      for s in $sizes; do
        for t in $threads; do
          "$build/obscura_bench" ao "$build/data/bunny.glb" --method sao --set max-mip=0 --blur off --size "$s" \
            --threads "$t" --reps "$aoreps" --warmup 2 | sed "s/^RESULT ao method=sao/RESULT rep=$r ao method=sao-peer-stage/"
          for m in $methods; do
            for b in off on; do
              "$build/obscura_bench" ao "$build/data/bunny.glb" --method "$m" --blur "$b" --size "$s" \
                --threads "$t" --reps "$aoreps" --warmup 2 | sed "s/^RESULT/RESULT rep=$r blur=$b/"
            done
          done
        done
      done
    done
  } | tee "$out"
  python3 - "$out" <<'PY' || true
import sys, re, statistics, collections
rows = collections.defaultdict(list)
for line in open(sys.argv[1]):
    if not line.startswith("RESULT"): continue
    kv = dict(re.findall(r"(\w+)=(\S+)", line))
    key = (kv["method"], kv.get("blur", "off"), kv["size"], kv["threads"])
    rows[key].append(tuple(float(kv[c]) for c in ("median_ms", "prepare_ms", "kernel_ms", "blur_ms", "coverage")))
print("| method | blur | size | threads | total ms | prepare ms | kernel ms | blur ms | coverage |")
print("|---|---|---|---|---|---|---|---|---|")
for k in sorted(rows):
    v = rows[k]
    med = [statistics.median(x[i] for x in v) for i in range(4)]
    print(f"| {k[0]} | {k[1]} | {k[2]} | {k[3]} | {med[0]:.2f} | {med[1]:.2f} | {med[2]:.2f} | {med[3]:.2f} | {v[0][4]:.3f} |")
PY
fi
