#!/usr/bin/env bash
# bench/run.sh: the G-buffer benchmark, one command. Builds Release if needed, then runs
# obscura_bench on the bunny and the dragon at 1920x1080 and 1280x720 with 1 and 2 threads,
# REPS interleaved repetitions (default 5), each the median of 20 timed frames after 5 warm-up
# frames. Prints RESULT lines and writes bench/results/gbuffer.txt; the table in
# docs/performance.md is the median over repetitions of each run's median.
# Usage: bench/run.sh [--quick]   (REPS=... THREADS="1 2" SIZES="1920x1080 1280x720" override)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${BUILD:-$here/build}"
if [ ! -x "$build/obscura_bench" ]; then "$here/scripts/build.sh" "$build"; fi
reps="${REPS:-5}"; threads="${THREADS:-1 2}"; sizes="${SIZES:-1920x1080 1280x720}"; frames=20
if [ "${1:-}" = "--quick" ]; then reps=1; sizes="640x360"; frames=3; fi
mkdir -p "$here/bench/results"
out="$here/bench/results/gbuffer.txt"
{
  echo "# $(date -u +%Y-%m-%dT%H:%MZ) $(uname -m) $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs) nproc=$(nproc)"
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
# Median over repetitions per configuration.
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
