#!/usr/bin/env bash
# Decode throughput of mimnav's VLP-16 driver library against velodyne-decoder 3.1.0 (PyPI), on
# the real dual-return capture, one after the other in the same run on the same machine.
#
#   bench/decode-vs-velodyne-decoder.sh [--seconds N]
#
# velodyne-decoder is installed into a virtual environment under target/ the first time (set
# VD_VENV to use another). Run it on an otherwise idle machine: both sides are single-threaded.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=3
if [ "${1:-}" = "--seconds" ]; then seconds=$2; fi
venv=${VD_VENV:-target/vd-venv}
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c 'import velodyne_decoder, dpkt, numpy' 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet velodyne-decoder==3.1.0 dpkt numpy
fi
cargo build --quiet --release -p mimnav-velodyne --bench decode
ours=$(cargo bench --quiet -p mimnav-velodyne --bench decode -- --seconds "$seconds" --json)
# velodyne-decoder's per-packet API (what a driver fed from a socket calls) and its fastest,
# ScanDecoder on a PacketVector prepared outside the timed loop: both ratios are reported
stream=$("$venv/bin/python" bench/velodyne_decoder_baseline.py --seconds "$seconds" --json --api stream)
scan=$("$venv/bin/python" bench/velodyne_decoder_baseline.py --seconds "$seconds" --json --api scan)
python3 - "$ours" "$stream" "$scan" <<'PY'
import json, sys
ours, stream, scan = (json.loads(a) for a in sys.argv[1:4])
print(f"mimnav-velodyne                     : {ours['packets_per_s']:>9.0f} packets/s  {ours['points_per_s']/1e6:6.1f} M points/s")
for name, t in (("StreamDecoder, per packet", stream), ("ScanDecoder on a PacketVector", scan)):
    print(f"velodyne-decoder {name:<19}: {t['packets_per_s']:>9.0f} packets/s  {t['points_per_s']/1e6:6.1f} M points/s"
          f"  (mimnav {ours['packets_per_s']/t['packets_per_s']:.1f}x its packets/s)")
PY
