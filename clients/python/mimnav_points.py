#!/usr/bin/env python3
"""Prints one line per lidar revolution (and per planar scan) a mimnav stack publishes.

Each line is ``key=value`` pairs, counted from the payload itself and from its header, so they
can be compared (tests/python_client.rs does):

    points seq=0 n=14981 point_count=14981 strongest=... h_strongest=... ... cut=0
    scan seq=0 n=1834 count=1834 laser=14

Ends after the driver's end-of-stream event (a replay's end), on SIGINT/SIGTERM, or after
``--timeout`` seconds. Prints ``READY`` once it is subscribed: start the driver after that, since
the topics keep no history.

    python3 mimnav_points.py --root-path /tmp/mimnav/iceoryx2/ --prefix mimnav_
"""

import argparse
import math
import sys
import time

import iceoryx2 as iox2

import mimnav_client as mc


def point_stats(msg) -> str:
    h, items = msg.header, msg.items
    raw = bytes(items)  # the revolution's records, 24 bytes each (docs/topics.md)
    size = mc.ctypes.sizeof(mc.Point)
    kinds = raw[mc.Point.return_type.offset :: size]
    rings = raw[mc.Point.ring.offset :: size]
    lasers = raw[mc.Point.laser_id.offset :: size]
    # every 7th point through the ctypes fields: the range from x, y, z must be the raw distance
    worst = 0.0
    min_raw = None
    for i in range(0, len(items), 7):
        p = items[i]
        err = abs(math.sqrt(p.x * p.x + p.y * p.y + p.z * p.z) - p.distance_raw * 0.002)
        worst = max(worst, err)
        min_raw = p.distance_raw if min_raw is None else min(min_raw, p.distance_raw)
    fields = {
        "seq": h.seq,
        "n": len(items),
        "point_count": h.point_count,
        "strongest": kinds.count(1),
        "last": kinds.count(2),
        "both": kinds.count(3),
        "h_strongest": h.strongest_count,
        "h_last": h.last_count,
        "h_both": h.both_count,
        "max_ring": max(rings, default=0),
        "max_laser": max(lasers, default=0),
        "min_distance_raw": min_raw if min_raw is not None else 0,
        "max_range_error_mm": f"{worst * 1000:.3f}",
        "packets": h.packet_count,
        "cut": h.cut_reason,
    }
    return "points " + " ".join(f"{k}={v}" for k, v in fields.items())


def scan_stats(msg) -> str:
    h, items = msg.header, msg.items
    return f"scan seq={h.seq} n={len(items)} count={h.count} laser={h.laser_id}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root-path", default=mc.DEFAULT_ROOT_PATH)
    ap.add_argument("--prefix", default=mc.DEFAULT_PREFIX)
    ap.add_argument("--timeout", type=float, default=0.0, help="seconds; 0: none")
    args = ap.parse_args()

    mc.check_layouts()
    node = mc.node("mimnav-points-py", args.root_path, args.prefix)
    points = mc.Subscriber(node, mc.LIDAR_POINTS)
    scans = mc.Subscriber(node, mc.LIDAR_SCAN2D)
    print("READY", flush=True)

    until = time.monotonic() + args.timeout if args.timeout > 0 else math.inf
    ended = {"points": False, "scan": False}
    while not all(ended.values()):
        if time.monotonic() > until:
            print("TIMEOUT", flush=True)
            return 2
        try:
            heard = points.wait(0.1)
        except iox2.ListenerWaitError:
            break  # SIGINT or SIGTERM
        for msg in points.receive_all():
            print(point_stats(msg), flush=True)
        for msg in scans.receive_all():
            print(scan_stats(msg), flush=True)
        ended["points"] |= heard.end_of_stream
        ended["scan"] |= scans.heard().end_of_stream
    print("END", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
