#!/usr/bin/env bash
# The Zenoh bridge's cost at its default rates (issue 25): bytes a second it sends and its CPU per
# revolution, with the stack driving the open field in real time (600 rpm: 10 revolutions a
# second) and one remote subscriber (PyPI's eclipse-zenoh, tests/zenoh_peer.py) taking every
# default topic over loopback TCP. Everything runs in a private iceoryx2 domain; Zenoh listens on
# 127.0.0.1 only, without scouting.
#
#   bench/zenoh-bridge.sh [--seconds N] [--profile release|debug]
#
# Needs target/zenoh-venv (.ci/run makes it) and the binaries of the profile (built here).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=30 profile=release
while [ $# -gt 0 ]; do
  case $1 in
    --seconds) seconds=$2; shift 2 ;;
    --profile) profile=$2; shift 2 ;;
    *) echo "usage: $0 [--seconds N] [--profile release|debug]" >&2; exit 2 ;;
  esac
done
python=${ZENOH_PYTHON:-target/zenoh-venv/bin/python}
"$python" -c 'import zenoh' || { echo "no eclipse-zenoh at $python: run .ci/run" >&2; exit 1; }
flag=$([ "$profile" = release ] && echo --release || true)
cargo build --quiet $flag -p mimnav --bins
bin=${CARGO_TARGET_DIR:-target}/$profile
tmp=$(mktemp -d /tmp/mimnav-zenoh-bench.XXXXXX)
port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
udp() { python3 -c 'import socket; s=socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'; }
dp=$(udp) pp=$(udp)
cat > "$tmp/zenoh.json5" <<J
{ mode: "peer", listen: { endpoints: ["tcp/127.0.0.1:$port"] },
  scouting: { multicast: { enabled: false }, gossip: { enabled: false } } }
J
args=(--config config/mimnav.toml
  --set "iceoryx2.global.root-path=\"$tmp/iox2/\"" --set "iceoryx2.global.prefix=\"zb$$_\""
  --set 'velodyne.input="udp"' --set 'velodyne.bind_address="127.0.0.1"'
  --set "velodyne.data_port=$dp" --set "velodyne.position_port=$pp" --set 'sim.udp_target="127.0.0.1"')
pids=()
# the run's own domain: its root path and the segments of its prefix (iceoryx2 leaves the 16-byte
# global management segment behind by design)
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done; wait 2>/dev/null || true
  rm -rf "$tmp"; rm -f /dev/shm/zb$$_*; }
trap cleanup EXIT
for s in mimnav-velodyne mimnav-mapper mimnav-planner mimnav-foliage; do
  "$bin/$s" "${args[@]}" 2>/dev/null & pids+=($!)
done
"$bin/mimnav-zenoh" "${args[@]}" --set zenoh.enabled=true --set 'zenoh.robot="bench"' \
  --set "zenoh.config_file=\"$tmp/zenoh.json5\"" 2>"$tmp/bridge.log" & bridge=$!; pids+=($bridge)
sleep 1
"$bin/mimnav-sim" "${args[@]}" --set sim.endless=true --seconds $((seconds + 30)) \
  --world config/worlds/open_field.toml >/dev/null 2>&1 & pids+=($!)
PYTHONPATH=clients/python "$python" -u tests/zenoh_peer.py "tcp/127.0.0.1:$port" bench \
  lidar/points map/plan odom cmd_vel base/state foliage/alarm < <(sleep $((seconds + 20))) >"$tmp/peer.jsonl" & pids+=($!)
sleep 8   # the stack settles, the peer connects
ticks() { awk '{print $14 + $15}' "/proc/$bridge/stat"; }
t0=$(ticks) n0=$(wc -l < "$tmp/peer.jsonl")
sleep "$seconds"
t1=$(ticks) n1=$(wc -l < "$tmp/peer.jsonl")
hz=$(getconf CLK_TCK)
python3 - "$tmp/peer.jsonl" "$n0" "$n1" "$t0" "$t1" "$hz" "$seconds" <<'PY'
import json, sys
path, n0, n1, t0, t1, hz, secs = sys.argv[1], *map(int, sys.argv[2:])
lines = open(path).read().splitlines()[n0:n1]
per = {}
for l in lines:
    v = json.loads(l)
    if v.get("event") == "sample":
        c = per.setdefault(v["topic"], [0, 0])
        c[0] += 1; c[1] += v["bytes"]
total = sum(b for _, b in per.values())
for t, (n, b) in sorted(per.items()):
    print(f"{t:<14} {n / secs:6.2f} msg/s {b / secs / 1e3:9.1f} kB/s")
cpu_s = (t1 - t0) / hz
revs = 10 * secs  # 600 rpm
print(f"received by the peer: {total / secs / 1e3:.1f} kB/s over {secs} s")
print(f"bridge CPU: {cpu_s:.2f} s in {secs} s ({100 * cpu_s / secs:.1f} % of one core), "
      f"{1e3 * cpu_s / revs:.2f} ms per revolution ({revs} revolutions)")
PY
kill -TERM "$bridge"; wait "$bridge" 2>/dev/null || true
grep -o 'bridged: .*' "$tmp/bridge.log" | tail -1
