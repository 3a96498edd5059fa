#!/bin/bash
# The idle-machine measurements of this session (run after every helper stopped).
cd /work/main
B=build
out=bench/results/session-20261202d.txt
{
echo "# $(date -u +%FT%TZ) idle check: load $(cut -d' ' -f1-3 /proc/loadavg); $(nproc) CPUs; $(lscpu | grep 'Model name' | sed 's/  */ /g')"
echo "## light volume (obscura_bench_volume --lv-only, bucky 256^3)"
echo "--light 0,0,1 (the bar's case), 2 threads:"; $B/obscura_bench_volume --lv-only --light 0,0,1 --threads 2 --reps 7 | grep -E "RESULT|BAR"
echo "--light 0,0,1, 1 thread:"; $B/obscura_bench_volume --lv-only --light 0,0,1 --threads 1 --reps 5 | grep -E "RESULT|BAR"
echo "--light -0.4,-0.7,-0.6 (blended), 2 threads:"; $B/obscura_bench_volume --lv-only --threads 2 --reps 5 | grep -E "RESULT|BAR"
echo "--light 0,0,1, 2 threads, fresh against rebuild into the warm volume (vol_light_volume_rebuild):"; $B/obscura_bench_volume --lv-only --light 0,0,1 --threads 2 --reps 7 --rebuild | grep -E "RESULT|BAR|^#"
echo "## sss maps (obscura_bench_sss, bunny_cream, K16 N48 512^2, 2 threads)"
$B/obscura_bench_sss $B/data/bunny_cream.glb --threads 2 --reps 5 | grep -E "RESULT|BAR"
$B/obscura_bench_sss $B/data/bunny_cream.glb --threads 2 --reps 5 --sampler russian-roulette | grep -E "RESULT|BAR"
echo "## render, 8 views of bunny_cream at 1920x1080, page faults with and without a kept heap"
C="--camera 0 --camera 1 --camera 0 --camera 1 --camera 0 --camera 1 --camera 0 --camera 1"
for e in "A=1" "MALLOC_MMAP_THRESHOLD_=33554432 MALLOC_TRIM_THRESHOLD_=536870912" "A=1" "MALLOC_MMAP_THRESHOLD_=33554432 MALLOC_TRIM_THRESHOLD_=536870912"; do
  echo "env $e:"; env $e /usr/bin/time -f "  %e s wall %U user %S sys %R minor-faults %M KB max RSS" $B/obscura --threads 2 render $B/data/bunny_cream.glb --size 1920x1080 $C -o /tmp/rb8 2>&1 | tail -1
done
} 2>&1 | tee "$out"
bench/run.sh sweep 2>&1 | tail -40 | tee -a "$out"
PAIRS=5 OBS_REPS=3 VTK_CASES="ea:1920x1080:full phong:1920x1080:full" bench/run.sh vtk 2>&1 | tail -30 | tee -a "$out"
cp bench/results/vtk-$(date -u +%Y%m%d).txt bench/results/vtk-$(date -u +%Y%m%d)-idle.txt
OBS_FLAGS=--fast PAIRS=5 OBS_REPS=3 VTK_CASES="ea:1920x1080:full phong:1920x1080:full" bench/run.sh vtk 2>&1 | tail -30 | tee -a "$out"
cp bench/results/vtk-$(date -u +%Y%m%d).txt bench/results/vtk-$(date -u +%Y%m%d)-idle-fast.txt
git checkout bench/results/vtk-$(date -u +%Y%m%d).txt 2>/dev/null || true
