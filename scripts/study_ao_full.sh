#!/bin/sh
# The AO study committed in docs/results/ao (issue 5), in resumable pieces: ground truths first
# (they need no idle machine), then the timed points (they do: run nothing else meanwhile), then
# the report from the table. Every step resumes: rerun the script after an interruption.
# Usage: scripts/study_ao_full.sh [BUILD_DIR] [OUT_DIR] [REPORT_DIR]   (see docs/study.md)
set -eu
B=${1:-build}
OUT=${2:-out/study-ao}
REP=${3:-docs/results/ao}
S="$B/obscura study ao -o $OUT"
# 4K: every scene, view, technique, sample count and blur, at the middle radius (1 unit) only
K4="--resolutions 3840x2160 --radii 1"
$S --resolutions 1920x1080,1280x720 --truth-only
$S $K4 --truth-only
$S --resolutions 1920x1080
$S --resolutions 1280x720
$S $K4
$S --report-only --budgets 1,2,4,8,16,32,64 --report "$REP"
