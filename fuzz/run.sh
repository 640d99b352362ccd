#!/usr/bin/env bash
# Runs one fuzz target (nightly and cargo-fuzz needed: `cargo install cargo-fuzz`) on one core
# until RUNS executions (default 10 000 000) or SECONDS of time (default 3600), starting from
# the seed corpus (fuzz/seed.sh; made here when missing). Crashes go to fuzz/artifacts/TARGET/.
#   fuzz/run.sh TARGET [RUNS] [SECONDS]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
target="$1"
runs="${2:-10000000}"
secs="${3:-3600}"
cd "$root"
[ -d "fuzz/corpus/$target" ] || fuzz/seed.sh
mkdir -p "fuzz/artifacts/$target"
case "$target" in
  velodyne_stream) max_len=16384 ;;   # a window of 12 datagrams of a real capture
  capture) max_len=32768 ;;           # the seeds: 24 KiB heads of the real captures
  kobuki_frames) max_len=4096 ;;      # about 45 feedback frames, under a second of the base
  sick_cola) max_len=20000 ;;         # an LMS5xx telegram with five echoes is 17 kB in CoLa-B
  *) max_len=16384 ;;                 # the config and world files are under 8 KiB
esac
# -s none: no sanitizer (safe Rust; ASan halves the rate); -a: debug assertions and overflow
# checks on, so an arithmetic overflow or a debug_assert is a crash too
exec cargo +nightly fuzz run --fuzz-dir fuzz -s none -a "$target" "fuzz/corpus/$target" -- \
  -max_len="$max_len" -runs="$runs" -max_total_time="$secs" -rss_limit_mb=2048 \
  -timeout=10 -print_final_stats=1
