#!/usr/bin/env bash
# The control path's latency (a revolution's last packet to its cmd_vel, `mimnav demo`) with and
# without the Foxglove live view attached, in turns in one run on the same machine: a demo alone,
# then a demo with `mimnav-view` and a Foxglove client (tests/foxglove_client.py on PyPI's
# websockets) subscribed to every heavy channel (points, the three grids, the classified scan,
# transforms, path, commands, latency), reading all of it.
#
#   bench/view-latency.sh [RUNS] [-- DEMO OPTIONS…]     (default 3 runs of each)
#
# The client's venv is target/ws-venv (as .ci/run makes it). Prints each run's latency line and
# the ranges of p50 and p99 for each side.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
shift || true
[ "${1:-}" = "--" ] && shift
py=${MIMNAV_WS_PYTHON:-target/ws-venv/bin/python}
if ! "$py" -c 'import websockets, google.protobuf' 2>/dev/null; then
  python3 -m venv target/ws-venv
  target/ws-venv/bin/pip install --quiet websockets==15.0.1 protobuf==5.29.4
  py=target/ws-venv/bin/python
fi
cargo build --quiet --release -p mimnav
mimnav=${CARGO_TARGET_DIR:-target}/release/mimnav
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
topics=(/lidar/points /map/plan /map/layers /map/glass /foliage/scan /tf /odom /path /goal /cmd_vel /latency /view/stats)
targs=()
for t in "${topics[@]}"; do targs+=(--topic "$t"); done
for i in $(seq 1 "$runs"); do
  for side in alone viewer; do
    if [ $side = alone ]; then
      "$mimnav" demo --out "$out/map.png" "$@" > "$out/$side-$i.txt"
    else
      "$mimnav" demo --out "$out/map.png" --view "$port" "$@" > "$out/$side-$i.txt" &
      demo=$!
      # the client connects once the view serves (within a second of the start), and reads
      # until the demo ends
      for _ in $(seq 1 200); do
        # listening yet? (without connecting, which the server would log as a failed handshake)
        [ -n "$(ss -ltnH "sport = :$port")" ] && break
        sleep 0.05
      done
      "$py" tests/foxglove_client.py --url "ws://127.0.0.1:$port" "${targs[@]}" \
        --count 100000000 --seconds 600 > "$out/client-$i.txt" 2>/dev/null &
      client=$!
      wait "$demo"
      kill "$client" 2>/dev/null || true
      wait "$client" 2>/dev/null || true
      got=$(grep -c '"topic"' "$out/client-$i.txt" || true)
      echo "  (client received $got messages)"
    fi
    line=$(grep -o 'latency from .*' "$out/$side-$i.txt" || echo "no latency line")
    echo "$side $i: $line"
  done
done
python3 - "$out" "$runs" <<'PY'
import re, sys, pathlib
d, runs = pathlib.Path(sys.argv[1]), int(sys.argv[2])
for side in ("alone", "viewer"):
    p50, p99 = [], []
    for i in range(1, runs + 1):
        m = re.search(r"p50 ([\d.]+) ms, p99 ([\d.]+) ms", (d / f"{side}-{i}.txt").read_text())
        if m:
            p50.append(float(m[1])); p99.append(float(m[2]))
    if p50:
        print(f"{side:>6}: p50 {min(p50):.2f}–{max(p50):.2f} ms, p99 {min(p99):.2f}–{max(p99):.2f} ms over {len(p50)} runs")
PY
