#!/usr/bin/env bash
# Latency per hop over worlds of every family (issue 27 item 3): the stack as processes
# (`mimnav demo`: the simulator streaming UDP in real time, the driver, mapper, foliage
# classifier and planner, SCHED_FIFO where allowed) drives one generated world of each family
# (the report split's first world, never a tune world) and the two bundled scenarios 1 and 4.
# For each world it prints the demo's line (a revolution's last packet to its cmd_vel: p50,
# p99, max), the mapper's own processing, and the services' per-hop lines of the last 10 s
# (last packet → the revolution at the mapper, mapping, → map/plan sent; → the map at the
# planner, planning, → cmd_vel; → the scan at the classifier, classifying, → foliage/alarm).
#
#   bench/latency.sh [ROBOT] [FAMILY…]      (default turtlebot2, every family)
#   LATENCY_SET="velodyne.slice_packets=0" bench/latency.sh …   (config keys for every run)
#   LATENCY_WORLDS="scenario1 scenario4"     (only these bundled scenarios, none: "-")
#
# A world the robot does not finish still measures: the demo's numbers cover every revolution
# it drove.
set -euo pipefail
cd "$(dirname "$0")/.."
robot=${1:-turtlebot2}
shift || true
cargo build --quiet --release -p mimnav
mimnav=${CARGO_TARGET_DIR:-target}/release/mimnav
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
families=("$@")
if [ ${#families[@]} -eq 0 ]; then
  mapfile -t families < <("$mimnav" --config config/mimnav.toml worlds families | awk '{print $1}')
fi
sets=()
for s in ${LATENCY_SET:-}; do sets+=(--set "$s"); done
worlds=()
for s in ${LATENCY_WORLDS:-scenario1 scenario4}; do
  [ "$s" = - ] || worlds+=("$(ls config/worlds/"$s"_*.toml)")
done
for f in "${families[@]}"; do
  "$mimnav" --config config/mimnav.toml --set "robot.profile=\"$robot\"" worlds generate \
    --family "$f" --count 1 --split report --out "$out/$f" >/dev/null
  worlds+=("$(ls "$out/$f"/*.toml | head -1)")
done
for w in "${worlds[@]}"; do
  echo "== $(basename "$w" .toml) ($robot)"
  # a demo that does not reach the goal exits 1: its figures still count
  "$mimnav" --config config/mimnav.toml "${sets[@]}" demo --world "$w" --robot "$robot" --log info \
    --out "$out/map.png" >"$out/demo" 2>"$out/err" || true
  grep -E "latency from|mapper's own" "$out/demo" || echo "(the demo printed no latency)"
  grep "latency per hop" "$out/err" | tail -3 | sed -E 's/^.*INFO (mimnav_[a-z]+): latency per hop: /  \1: /' || true
done
