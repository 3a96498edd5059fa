#!/usr/bin/env bash
# bench/run.sh: obscura's benchmarks, one command. Builds Release if needed, then runs
#   side:    (the default) GLSL on Mesa llvmpipe against obscura, SIDE BY SIDE: the GLSL programs
#            and obscura run ALTERNATING in one run, PAIRS pairs (default 5), on the bunny at
#            1920x1080 with 2 threads; prints each pass's per-pair times, the medians and the
#            median of the per-pair ratios (GLSL / obscura), and writes bench/results/side.txt.
#            The llvmpipe peer (../shared/tools/llvmpipe-peer) is built into the build tree.
#   gbuffer: obscura_bench gbuffer on the bunny and the dragon at 1920x1080 and 1280x720 with 1 and
#            2 threads (median of 20 timed frames after 5 warm-up frames per run);
#   ao:      obscura_bench ao for every registered AO method, its reference blur off and on, on the
#            bunny (the llvmpipe peer's framing) at 1920x1080 and 1280x720 with 1 and 2 threads
#            (median of 9 timed runs after 2 warm-up runs per run), plus SAO as the peer's `sao`
#            stage (level 0 only, no blur);
#   sss:     obscura_bench_sss: the scattering maps of the bunny in cream at the bar's configuration
#            (K 16, N 48, 512^2, 2 threads; <= 150 ms), 8 views reusing one set of maps, then the
#            GLSL port of the gather and the combination on llvmpipe alternating with ours
#            -> bench/results/sss.txt (the cost growth in K, N and map size: sweep);
#   sweep:   the cost growth (issue 14 section 8, issue 15 item 11; docs/results/cost-growth.md):
#            obscura_bench_sss --sweep (the maps over K, N and map size, both samplers) and
#            obscura_bench_volume --growth (the light volume over n^3, the ray cast over n and over the
#            image size), each point a warm-up and the median of SWEEP_REPS (default 3), a least-squares
#            line per axis; 2 threads (SWEEP_THREADS); about 2.5 minutes idle (estimated); --quick: 1 repetition and
#            without the largest point of each axis -> bench/results/sweep-<yyyymmdd>.txt;
#   all:     side, gbuffer, ao and sss (not sweep, not vtk).
#   vtk:     (not in all) the volume ray caster against VTK 9.1's CPU ray caster
#            (vtkFixedPointVolumeRayCastMapper, Debian python3-vtk9, bench/vtk_peer.py under xvfb-run;
#            installed here with apt-get when missing), SIDE BY SIDE: `obscura volume` (its sidecar's
#            seconds_raycast) and the peer (one frame after a warm-up) alternate, PAIRS pairs (default
#            5), on the head CT with ct-skin, obscura's framing, step and light, 2 threads; cases: EA at
#            960x540, 1920x1080 and 3840x2160, EA on the CT down-sampled by 2, Phong at 1920x1080;
#            prints medians, the median of the per-pair ratios (VTK / obscura), a RATIO line against
#            the bar (>= 2x), the cost growth, and `obscura compare` of the two images per case;
#            writes bench/results/vtk-DATE.txt (--quick: vtk-DATE-quick.txt; docs/volume/vtk-peer.md).
# gbuffer and ao: REPS interleaved repetitions (default 5) of each. Prints RESULT lines and writes
# bench/results/{gbuffer,ao}.txt; the tables in docs/performance.md are the medians over
# repetitions of each run's median, which this script prints at the end.
# Usage: bench/run.sh [side|gbuffer|ao|sss|sweep|vtk|all] [--quick]
#   (vtk: PAIRS=5 THREADS=2 VTK_CASES="ea:1920x1080:full ..." VTK_REPS=1 OBS_REPS=1 VTK_INSTALL=1 override;
#    OBS_FLAGS="--fast" passes flags to obscura volume)
#   (side: PAIRS=5 THREADS=2 SIZE=1920x1080 FRAMES=20 WARMUP=5 PASSES="gbuffer sao sao_blur";
#    gbuffer/ao: REPS=... THREADS="1 2" SIZES="1920x1080 1280x720" METHODS="sao gtao" override)
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
build="${BUILD:-$here/build}"
what="side"; quick=0
for a in "$@"; do
  case "$a" in side|gbuffer|ao|sss|sweep|vtk|all) what="$a" ;; --quick) quick=1 ;; *) echo "usage: bench/run.sh [side|gbuffer|ao|sss|sweep|vtk|all] [--quick]" >&2; exit 2 ;; esac
done
# vtk needs only the CLI (built below, one target); everything else the whole Release build
if [ "$what" != vtk ] && [ ! -x "$build/obscura_bench" ]; then "$here/scripts/build.sh" "$build"; fi
reps="${REPS:-5}"; threads="${THREADS:-1 2}"; sizes="${SIZES:-1920x1080 1280x720}"; frames=20; aoreps=9
if [ "$quick" = 1 ]; then reps=1; sizes="640x360"; frames=3; aoreps=3; fi
mkdir -p "$here/bench/results"
header() { echo "# $(date -u +%Y-%m-%dT%H:%MZ) $(uname -m) $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs) nproc=$(nproc) load1=$(cut -d' ' -f1 /proc/loadavg)"; }

# ================================================================================================
# side: GLSL against obscura, alternating
# ================================================================================================
# Each pass is one entry of PASS_TABLE: name | GLSL command | GLSL parse | obscura command |
# obscura parse. A command is a shell command line (eval'd); its output goes through the parse,
# which prints that pass's milliseconds. Commands shared by several passes run once per pair (the
# peer times all its stages in one run, obscura_bench ao times SAO's kernel and blur in one).
# Parses: peer_stage STAGE (the peer's `RESULT ... stage=STAGE median_ms=X`), field NAME (the
# first RESULT line's NAME=X, as obscura_bench prints). A pass whose GLSL program is missing is
# skipped with a note. Then the project's own GLSL ports of every kernel and blur (tests/gl) run
# in obscura_gl_bench, which alternates GLSL and obscura itself (PAIRS pairs of GLREPS timed runs
# each; GL_ONLY=sao,gtao picks ports) and writes bench/results/side_gl.txt.
side_run() {
  local pairs="${PAIRS:-5}" t="${THREADS:-2}" size="${SIZE:-1920x1080}" fr="${FRAMES:-20}" wu="${WARMUP:-5}"
  local aoreps_side="${AOREPS:-$fr}"
  if [ "$quick" = 1 ]; then pairs=1; size="640x360"; fr=3; wu=1; aoreps_side=3; fi
  case "$t" in *" "*) echo "side: THREADS must be one number (got '$t')" >&2; exit 2 ;; esac
  local W="${size%x*}" H="${size#*x}"
  local peerdir="${PEER_DIR:-$here/../shared/tools/llvmpipe-peer}" mesh_off="${MESH_OFF:-$here/data/cache/bunny00.off}"
  local mesh_glb="$build/data/bunny.glb"
  # ---- the llvmpipe peer, built from its own Makefile into the build tree (never into its folder) ----
  peer="$build/llvmpipe-peer/peer"
  if [ ! -x "$peer" ] || [ "$peerdir/peer.c" -nt "$peer" ]; then
    mkdir -p "$build/llvmpipe-peer"
    make -s -C "$build/llvmpipe-peer" -f "$peerdir/Makefile" VPATH="$peerdir" peer >&2 ||
      { echo "side: cannot build the llvmpipe peer from $peerdir (EGL/Mesa packages: see its README)" >&2; exit 3; }
  fi
  [ -f "$mesh_off" ] || { echo "side: $mesh_off missing (scripts/setup.sh fetches the meshes)" >&2; exit 3; }
  # ---- the GLSL programs and obscura's commands the entries use ----
  gl_harness="${GL_HARNESS:-$build/obscura_gl_bench}"   # tests/gl: every kernel's GLSL port (alternates itself)
  glsl_peer="LIBGL_ALWAYS_SOFTWARE=1 GALLIUM_DRIVER=llvmpipe LP_NUM_THREADS=$t \"$peer\" \"$mesh_off\" --w $W --h $H --frames $fr --warmup $wu"
  obs_gbuffer="\"$build/obscura_bench\" gbuffer \"$mesh_glb\" --outputs peer --size ${W}x$H --threads $t --reps $fr --warmup $wu"
  obs_ao="\"$build/obscura_bench\" ao \"$mesh_glb\" --size ${W}x$H --threads $t --reps $aoreps_side --warmup 2"
  # ---- the passes: name | GLSL command | GLSL parse | obscura command | obscura parse ----
  local PASS_TABLE=(
    "gbuffer|$glsl_peer|peer_stage gbuffer|$obs_gbuffer|field median_ms"
    "sao|$glsl_peer|peer_stage sao|$obs_ao --method sao --set max-mip=0 --blur on|field kernel_ms"
    "sao_blur|$glsl_peer|peer_stage blur|$obs_ao --method sao --set max-mip=0 --blur on|field blur_ms"
  )
  local want="${PASSES:-$(printf '%s\n' "${PASS_TABLE[@]}" | cut -d'|' -f1 | xargs)}"
  local out="$here/bench/results/side.txt"
  {
    header
    echo "# side by side: $pairs pairs, ${W}x$H, $t threads, GLSL first in each pair; passes: $want"
    for p in $(seq 1 "$pairs"); do
      declare -A cache=()
      for e in "${PASS_TABLE[@]}"; do
        IFS='|' read -r name gcmd gparse ocmd oparse <<<"$e"
        case " $want " in *" $name "*) ;; *) continue ;; esac
        local gbin; gbin=$(eval "set -- $gcmd"; for w in "$@"; do case "$w" in *=*) ;; *) echo "$w"; break ;; esac; done)
        if [ ! -x "$gbin" ]; then [ "$p" = 1 ] && echo "# $name: skipped, no GLSL program $gbin"; continue; fi
        # GLSL side, then obscura's (each command once per pair)
        local side g o
        for side in g o; do
          local cmd; if [ $side = g ]; then cmd="$gcmd"; else cmd="$ocmd"; fi
          if [ -z "${cache[$cmd]+x}" ]; then cache[$cmd]="$(eval "$cmd" 2>/dev/null | grep '^RESULT' || true)"; fi
        done
        g=$(printf '%s\n' "${cache[$gcmd]}" | parse $gparse)
        o=$(printf '%s\n' "${cache[$ocmd]}" | parse $oparse)
        echo "PAIR pair=$p pass=$name glsl_ms=${g:-nan} obscura_ms=${o:-nan}"
      done
      unset cache
    done
  } | tee "$out"
  python3 - "$out" <<'PY' || true
import sys, re, statistics as S, collections
bars = {"gbuffer": 4.0}  # issue 13: G-buffer >= 4x, every kernel and blur >= 3x
d = collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith("PAIR"):
        kv = dict(re.findall(r"(\w+)=(\S+)", line))
        try: d[kv["pass"]].append((float(kv["glsl_ms"]), float(kv["obscura_ms"])))
        except ValueError: pass
print("| pass | obscura ms | GLSL (llvmpipe) ms | ratio (median of pairs) | pairs min-max | bar |")
print("|---|---|---|---|---|---|")
for k, v in d.items():
    r = [g / o for g, o in v if o > 0]
    bar = bars.get(k, 3.0)
    print(f"| {k} | {S.median(o for _, o in v):.2f} | {S.median(g for g, _ in v):.2f} | {S.median(r):.2f}x | "
          f"{min(r):.2f}-{max(r):.2f} | >= {bar:g}x {'met' if S.median(r) >= bar else 'NOT met'} |")
PY
  # ---- the project's own GLSL ports of every kernel and blur (tests/gl), alternating in one process ----
  local gout="$here/bench/results/side_gl.txt"
  if [ ! -x "$gl_harness" ]; then echo "# the GLSL ports: skipped, no $gl_harness (build the tests: OBS_BUILD_TESTS)"; return 0; fi
  {
    header
    "$gl_harness" "$mesh_glb" --size "${W}x$H" --threads "$t" --pairs "$pairs" --reps "${GLREPS:-5}" ${GL_ONLY:+--only "$GL_ONLY"}
  } | tee "$gout"
  python3 - "$gout" <<'PY' || true
import sys, re
print("| pass | stage | obscura ms | GLSL (llvmpipe) ms | ratio (median of pairs) | pairs min-max | bar |")
print("|---|---|---|---|---|---|---|")
for line in open(sys.argv[1]):
    if not line.startswith("SUMMARY"): continue
    kv = dict(re.findall(r'(\w+)=("[^"]*"|\S+)', line))
    r = float(kv["ratio"])
    print(f"| {kv['pass']} ({kv['variant'].strip(chr(34))}) | {kv['stage']} | {float(kv['obscura_ms']):.2f} | {float(kv['glsl_ms']):.2f} | "
          f"{r:.2f}x | {kv['ratio_min']}-{kv['ratio_max']} | >= 3x {'met' if r >= 3 else 'NOT met'} |")
PY
}

# parse KIND ARG < RESULT lines: the pass's milliseconds
parse() {
  case "$1" in
    peer_stage) awk -v s="$2" '{ for (i = 1; i <= NF; i++) if ($i == "stage=" s) { for (j = 1; j <= NF; j++) if ($j ~ /^median_ms=/) { sub(/^median_ms=/, "", $j); print $j; exit } } }' ;;
    field) awk -v f="$2" '{ for (i = 1; i <= NF; i++) if (index($i, f "=") == 1) { print substr($i, length(f) + 2); exit } }' ;;
    *) echo "parse: unknown kind $1" >&2; return 2 ;;
  esac
}

# ================================================================================================
# vtk: obscura's volume ray caster against VTK 9.1's CPU ray caster, alternating
# ================================================================================================
# Each case is MODE:WxH:VOLUME (VOLUME full = the head CT, half = it down-sampled by 2 per axis by
# vtk_peer.py --write-half into the build tree). Per pair: `obscura volume --reps OBS_REPS` once
# (default 1: its first ray cast, then one warm-up and OBS_REPS warm casts with the brick table
# prepared once; obscura_ms is the warm median, seconds_raycast_warm, like the peer's warm Render();
# obscura_cold_ms is the first cast, brick table included; loading excluded from both), then the peer once (one timed Render() after one
# warm-up, loading excluded), with the camera and light read from obscura's sidecar. The images of
# the last pair are compared with `obscura compare` (linear RGB over black: obscura's EXR against
# the peer's PFM read back from VTK's 8-bit frame buffer).
vtk_run() {
  local pairs="${PAIRS:-5}" t="${THREADS:-2}" vreps="${VTK_REPS:-1}" tf="${VTK_TF:-ct-skin}" oreps="${OBS_REPS:-1}"
  local cases="${VTK_CASES:-ea:1920x1080:full ea:960x540:full ea:3840x2160:full ea:1920x1080:half phong:1920x1080:full}"
  if [ "$quick" = 1 ]; then pairs=1; cases="ea:640x360:full"; fi
  case "$t" in *" "*) echo "vtk: THREADS must be one number (got '$t')" >&2; exit 2 ;; esac
  local vol="${VTK_VOLUME:-$here/data/cache/volumes/cranium.nrrd}" py="${VTK_PYTHON:-/usr/bin/python3}"
  [ -f "$vol" ] || { echo "vtk: $vol missing (scripts/fetch_volumes.sh, run by scripts/setup.sh, extracts it)" >&2; exit 3; }
  # ---- the CLI (one target, -j1 when it has to be built) and the peer (Debian packages, not in CI's setup) ----
  if [ ! -x "$build/obscura" ]; then
    cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null && cmake --build "$build" -j1 --target obscura_cli >&2
  fi
  if ! "$py" -c 'import vtk, numpy' 2>/dev/null || ! command -v xvfb-run >/dev/null; then
    if [ "${VTK_INSTALL:-1}" = 1 ] && command -v apt-get >/dev/null; then
      local SUDO=""; [ "$(id -u)" = 0 ] || SUDO="sudo"
      $SUDO apt-get install -y -qq python3-vtk9 xvfb >&2 || { echo "vtk: apt-get install python3-vtk9 xvfb failed" >&2; exit 3; }
    else
      echo "vtk: needs python3-vtk9 (for $py) and xvfb-run: apt-get install python3-vtk9 xvfb" >&2; exit 3
    fi
  fi
  local work="$build/vtk-peer"; mkdir -p "$work"
  local half="$work/$(basename "${vol%.nrrd}")_half.nrrd"
  if [ ! -f "$half" ] || [ "$vol" -nt "$half" ]; then "$py" "$here/bench/vtk_peer.py" "$vol" --write-half "$half" >&2; fi
  local out; out="$here/bench/results/vtk-$(date -u +%Y%m%d)$([ "$quick" = 1 ] && echo -quick || true).txt"
  {
    header
    echo "# obscura volume against VTK $("$py" -c 'import vtk; print(vtk.vtkVersion.GetVTKVersion())') vtkFixedPointVolumeRayCastMapper: $pairs pairs, $t threads, TF $tf, obscura first in each pair; cases: $cases"
    for c in $cases; do
      IFS=: read -r mode size which <<<"$c"
      local v="$vol"; [ "$which" = half ] && v="$half"
      local tag="${mode}_${size}_$which"
      for p in $(seq 1 "$pairs"); do
        "$build/obscura" --quiet --threads "$t" volume "$v" --tf "$tf" --mode "$mode" --size "$size" --reps "$oreps" ${OBS_FLAGS:-} -o "$work/obs_$tag" >/dev/null 2>&1 ||
          { echo "# $tag: obscura volume failed"; continue 2; }
        local o; o=$(awk -F'[:,]' '/"seconds_raycast_warm"/ { gsub(/ /, "", $2); printf "%.1f", $2 * 1000 }' "$work/obs_$tag.json")
        local oc; oc=$(awk -F'[:,]' '/"seconds_raycast"/ { gsub(/ /, "", $2); printf "%.1f", $2 * 1000 }' "$work/obs_$tag.json")
        local r; r=$(xvfb-run -a "$py" "$here/bench/vtk_peer.py" "$v" --tf "$tf" --mode "$mode" --size "$size" --threads "$t" \
                     --camera-from "$work/obs_$tag.json" --warmup 1 --reps "$vreps" --out "$work/vtk_$tag" 2>/dev/null | grep '^RESULT' || true)
        local g; g=$(printf '%s\n' "$r" | parse field median_ms)
        [ "$p" = 1 ] && [ -n "$r" ] && echo "# peer: ${r#RESULT }"
        echo "PAIR case=$tag pair=$p vtk_ms=${g:-nan} obscura_ms=${o:-nan} obscura_cold_ms=${oc:-nan} load1=$(cut -d' ' -f1 /proc/loadavg)"
      done
      echo "# compare $tag: reference obscura ($work/obs_$tag.exr), test VTK ($work/vtk_$tag.pfm), R G B over black"
      "$build/obscura" compare "$work/obs_$tag.exr" "$work/vtk_$tag.pfm" --channel R --channel G --channel B \
        --heatmap "$work/heat_$tag.png" --json "$work/cmp_$tag.json" 2>&1 | sed 's/^/COMPARE /' || true
    done
    echo "# end $(date -u +%Y-%m-%dT%H:%MZ) load1=$(cut -d' ' -f1 /proc/loadavg)"
  } | tee "$out"
  python3 - "$out" <<'PY' || true
import sys, re, statistics as S, collections
d = collections.defaultdict(list)
for line in open(sys.argv[1]):
    if line.startswith("PAIR"):
        kv = dict(re.findall(r"(\w+)=(\S+)", line))
        try: d[kv["case"]].append((float(kv["vtk_ms"]), float(kv["obscura_ms"]), float(kv["load1"])))
        except ValueError: pass
print("| case | obscura ms | VTK ms | obscura speed-up = VTK ms / obscura ms (median of pairs) | pairs min-max | load1 | bar |")
print("|---|---|---|---|---|---|---|")
med = {}
for k, v in d.items():
    r = [g / o for g, o, _ in v if o > 0]
    med[k] = (S.median(o for _, o, _ in v), S.median(g for g, _, _ in v))
    print(f"| {k} | {med[k][0]:.1f} | {med[k][1]:.1f} | {S.median(r):.2f}x | {min(r):.2f}-{max(r):.2f} | "
          f"{S.median(l for _, _, l in v):.1f} | >= 2x {'met' if S.median(r) >= 2 else 'NOT met'} |")
    if k == "ea_1920x1080_full":
        print(f"RATIO vtk_over_obscura case={k} median={S.median(r):.2f} bar=2 {'met' if S.median(r) >= 2 else 'NOT_met'}")
# cost growth: against the 1920x1080 full-volume EA case
base = med.get("ea_1920x1080_full")
if base:
    print("| growth against ea_1920x1080_full | obscura | VTK |")
    print("|---|---|---|")
    for k in ("ea_960x540_full", "ea_3840x2160_full", "ea_1920x1080_half", "phong_1920x1080_full"):
        if k in med:
            print(f"| {k} | {med[k][0] / base[0]:.2f}x | {med[k][1] / base[1]:.2f}x |")
PY
}

if [ "$what" = vtk ]; then vtk_run; exit 0; fi
if [ "$what" = side ] || [ "$what" = all ]; then side_run; fi
[ "$what" = side ] && exit 0

if [ "$what" = sss ] || [ "$what" = all ]; then
  sreps=7; [ "$quick" = 1 ] && sreps=1
  { header
    "$build/obscura_bench_sss" "$build/data/bunny_cream.glb" --threads 2 --reps "$sreps" --views 8
    # (the cost growth in K, N and map size is `bench/run.sh sweep`)
    # the GLSL port of the gather and the combination on llvmpipe, alternating with ours (tests/gl/glsl_sss.c)
    if [ -x "$build/obscura_gl_bench_sss" ]; then
      "$build/obscura_gl_bench_sss" "$build/data/bunny_cream.glb" --K 16 --N 48 --map 256 --threads 2
    fi
  } | tee "$here/bench/results/sss.txt"
  if [ "$what" = sss ]; then exit 0; fi
fi
# ================================================================================================
# sweep: the cost growth in K, N, map size (SSS maps) and in volume and image size (light volume,
# ray caster); each axis's table ends in a FIT line (t = a + b x, R^2, the worst relative residual)
# ================================================================================================
if [ "$what" = sweep ]; then
  sw_reps="${SWEEP_REPS:-3}"; sw_threads="${SWEEP_THREADS:-2}"; sw_extra=()
  if [ "$quick" = 1 ]; then sw_reps=1; sw_extra=(--no-largest); fi
  for x in obscura_bench_sss obscura_bench_volume; do
    [ -x "$build/$x" ] || cmake --build "$build" -j1 --target "$x" >&2
  done
  out="$here/bench/results/sweep-$(date -u +%Y%m%d).txt"
  t_sweep=$(date +%s)
  { header
    "$build/obscura_bench_sss" "$build/data/bunny_cream.glb" --threads "$sw_threads" --reps "$sw_reps" --sweep ${sw_extra[@]+"${sw_extra[@]}"}
    "$build/obscura_bench_volume" --growth --threads "$sw_threads" --reps "$sw_reps" ${sw_extra[@]+"${sw_extra[@]}"}
    echo "# sweep: $(( $(date +%s) - t_sweep )) s in all; load1 at the end $(cut -d' ' -f1 /proc/loadavg)"
  } | tee "$out"
  echo "# the fits (docs/results/cost-growth.md says how to read them):"
  grep '^FIT' "$out" || true
  exit 0
fi

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
