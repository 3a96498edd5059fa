#!/bin/bash
# The idle-machine measurements of this session (2026-12-02, evening; run after every helper stopped).
cd /work/main
B=build
out=bench/results/session-20261202e.txt
{
echo "# $(date -u +%FT%TZ) idle check: load $(cut -d' ' -f1-3 /proc/loadavg); $(nproc) CPUs; $(lscpu | grep 'Model name' | sed 's/  */ /g')"
echo "## light volume (obscura_bench_volume --lv-only, bucky 256^3, light along +z, 3x3 cone)"
echo "2 threads, fresh and rebuild into the warm volume:"; $B/obscura_bench_volume --lv-only --light 0,0,1 --threads 2 --reps 9 --rebuild | grep -E "RESULT|BAR|^#"
echo "1 thread, rebuild:"; $B/obscura_bench_volume --lv-only --light 0,0,1 --threads 1 --reps 7 --rebuild | grep -E "RESULT|BAR"
echo "2 threads, OBS_ISA=avx2 (no AVX-512), rebuild:"; OBS_ISA=avx2 $B/obscura_bench_volume --lv-only --light 0,0,1 --threads 2 --reps 7 --rebuild | grep -E "RESULT|BAR"
echo "oblique (-0.4,-0.7,-0.6), blended, 2 threads:"; $B/obscura_bench_volume --lv-only --threads 2 --reps 5 | grep -E "RESULT|BAR"
echo "## sss maps (obscura_bench_sss, bunny_cream, K16 N48 512^2, 2 threads; fresh build and rebuild)"
$B/obscura_bench_sss $B/data/bunny_cream.glb --threads 2 --reps 9 --sampler russian-roulette | grep -E "RESULT|REBUILD|BAR"
$B/obscura_bench_sss $B/data/bunny_cream.glb --threads 2 --reps 5 | grep -E "RESULT|REBUILD|BAR"
echo "## sss maps against their GLSL port on llvmpipe (RR, K16 N48 256^2, 3 alternating pairs)"
$B/obscura_gl_bench_sss $B/data/bunny_cream.glb --K 16 --N 48 --map 256 --threads 2 2>&1 | grep -E "RESULT|RATIO|BAR|pair"
echo "## SSS brute-force reference: its shadow rays against raw flat rtcOccluded1M (obscura_bench_truth --sss)"
$B/obscura_bench_truth --sss 2>&1 | grep -E "RESULT|RATIO|^#"
echo "## process start: obscura --help, 20 runs"
/usr/bin/time -f "  %e s for 20" bash -c "for i in \$(seq 20); do $B/obscura --help >/dev/null; done"
} 2>&1 | tee "$out"
echo "## the volume study, full grid (obscura study volume -> docs/results/volume)" | tee -a "$out"
rm -rf out/study-volume
/usr/bin/time -f "  study: %e s wall" $B/obscura study volume -o out/study-volume --report docs/results/volume 2>&1 | grep -v "^\[" | tee -a "$out"
for f in "" "--fast"; do
  OBS_FLAGS="$f" PAIRS=5 OBS_REPS=3 VTK_CASES="ea:1920x1080:full phong:1920x1080:full" bench/run.sh vtk 2>&1 | tail -30 | tee -a "$out"
  cp bench/results/vtk-$(date -u +%Y%m%d).txt bench/results/vtk-$(date -u +%Y%m%d)-idle-e${f:+-fast}.txt
done
git checkout bench/results/vtk-$(date -u +%Y%m%d).txt 2>/dev/null || true
