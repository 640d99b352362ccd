#!/usr/bin/env bash
# Builds the fuzz targets' seed corpora in fuzz/corpus/TARGET/ (gitignored): from the real
# captures in ../shared/data/velodyne (read at run time, never copied into the repository) and
# the repository's config/ and config/worlds/. Run from anywhere; `fuzz/seed.sh DIR` writes to DIR.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:-$root/fuzz/corpus}"
cd "$root"
cargo run --quiet -p mimnav-fuzz-bodies --example seed -- "$out"
