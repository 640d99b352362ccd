#!/usr/bin/env python3
"""Baseline decode throughput of the reference decoder velodyne-decoder (PyPI 3.1.0).

Reads every 1206-byte UDP payload of a VLP-16 capture into memory once (dpkt; classic pcap in
either byte order / us or ns, or pcapng; link types Ethernet incl. 802.1Q, Linux SLL, raw IPv4,
BSD loopback -- the same handling as ../shared/tools/vlp_reference.py), then decodes them again
and again with velodyne-decoder, single-threaded, for at least --seconds, and prints e.g.

  velodyne-decoder 3.1.0: 95569 packets/s, 9.4 M points/s (dual capture, in memory, 1206 packets x 250 repeats)

Setup
  python3 -m venv /tmp/vd-venv && /tmp/vd-venv/bin/pip install velodyne-decoder==3.1.0 dpkt numpy
  /tmp/vd-venv/bin/python bench/velodyne_decoder_baseline.py [PCAP] [--json] [--api API]

PCAP defaults to <repo root>/../shared/data/velodyne/vlp16_dual_nebula.pcap.

--api (all use only the library's public API; config = Config(model=Model.VLP16), default
min_range 0.1 m, max_range 200 m, no cut angle, as vlp_reference.py):
  stream       (default) StreamDecoder.decode(stamp, payload_bytes) per packet -- exactly what
               vlp_reference.py does; clouds come back as (N, 8) float32 arrays. One decoder runs
               across all repeats (host stamps are shifted by one capture span per repeat so time
               keeps going forward) and finish() flushes the last revolution.
  stream-list  the same, but each payload is handed over as a Python list of ints made once in
               setup. The binding converts its `packet` argument element by element into a
               std::array<uint8_t, 1206>; a list converts about twice as fast as bytes.
  scan         ScanDecoder.decode(PacketVector) once per revolution. Packets are wrapped once in
               setup as VelodynePacket objects, grouped into the revolutions StreamDecoder
               produces, so the timed loop has no per-packet Python call or byte conversion.
  read_pcap    velodyne_decoder.read_pcap(path, config): the library's own pcap reading + decode,
               file I/O included (NOT in memory).
  all          each of the above, one line each.
--pcl-structs  pass as_pcl_structs=True (structured array, no copy into a float array).

Points are counted as the library returns them: len() of every returned cloud. velodyne-decoder
drops zero-distance records (in dual mode a last/strongest pair gives one point if both distances
are equal and non-zero, otherwise one point per non-zero distance) and anything outside
[min_range, max_range].

Note: velodyne_decoder.__version__ of the 3.1.0 wheel says "3.0.0" (the C++ project version was
not bumped); the version shown here comes from the installed distribution's metadata.

The machine has 2 cores: run it while nothing else is busy. If the timed loop got less than 90% of
a core (CPU time / wall time, also reported as "cpu_share" in --json), a warning goes to stderr.

Exit codes: 0 ok, 1 bad input, 2 velodyne-decoder / dpkt / numpy not importable.
"""
import argparse
import json
import os
import sys
import time

PACKET_SIZE = 1206
RETURN_MODES = {0x37: "strongest", 0x38: "last", 0x39: "dual"}
APIS = ("stream", "stream-list", "scan", "read_pcap")
INSTALL_HINT = "pip install velodyne-decoder==3.1.0 dpkt numpy"


def default_pcap():
    repo_root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    return os.path.normpath(os.path.join(repo_root, "..", "shared", "data", "velodyne",
                                         "vlp16_dual_nebula.pcap"))


def import_deps():
    try:
        import velodyne_decoder as vd
        import dpkt  # noqa: F401
        import numpy  # noqa: F401
    except ImportError as e:
        print("error: cannot import %s (%s).\n"
              "Install the reference decoder first, e.g.\n"
              "  python3 -m venv /tmp/vd-venv && /tmp/vd-venv/bin/pip install velodyne-decoder==3.1.0 dpkt numpy\n"
              "  (or: %s) and run this script with that interpreter."
              % (getattr(e, "name", None) or "velodyne_decoder", e, INSTALL_HINT), file=sys.stderr)
        sys.exit(2)
    return vd


def library_version(vd):
    try:
        from importlib.metadata import version
        return version("velodyne-decoder")
    except Exception:
        return getattr(vd, "__version__", "?")


def iter_udp(path, port=None):
    """Yield (pcap_ts, dst_port, udp_payload_bytes) for every UDP datagram (as vlp_reference.py)."""
    import dpkt
    with open(path, "rb") as f:
        magic = f.read(4)
        f.seek(0)
        reader = dpkt.pcapng.Reader(f) if magic == b"\x0a\x0d\x0d\x0a" else dpkt.pcap.Reader(f)
        dl = reader.datalink()
        for ts, buf in reader:
            try:
                if dl == dpkt.pcap.DLT_EN10MB:
                    ip = dpkt.ethernet.Ethernet(buf).data  # dpkt strips 802.1Q tags
                elif dl == dpkt.pcap.DLT_LINUX_SLL:
                    ip = dpkt.sll.SLL(buf).data
                elif dl in (dpkt.pcap.DLT_RAW, 12, 14):
                    ip = dpkt.ip.IP(buf)
                elif dl == dpkt.pcap.DLT_NULL:
                    ip = dpkt.ip.IP(buf[4:])
                else:
                    continue
            except (dpkt.UnpackError, IndexError):
                continue
            if not isinstance(ip, dpkt.ip.IP) or not isinstance(ip.data, dpkt.udp.UDP):
                continue
            udp = ip.data
            if port is not None and udp.dport != port:
                continue
            yield float(ts), udp.dport, bytes(udp.data)


def load_packets(path, port=None):
    return [(ts, data) for ts, _, data in iter_udp(path, port) if len(data) == PACKET_SIZE]


def make_config(vd):
    return vd.Config(model=vd.Model.VLP16)


def capture_span(packets):
    """Duration of one pass over the capture, plus one median packet gap."""
    if len(packets) < 2:
        return 1.0
    gaps = sorted(b[0] - a[0] for a, b in zip(packets, packets[1:]))
    return packets[-1][0] - packets[0][0] + max(gaps[len(gaps) // 2], 1e-6)


def reference_pass(vd, packets, pcl):
    """One untimed StreamDecoder pass: (points per pass, indices of the packets ending a frame)."""
    dec = vd.StreamDecoder(make_config(vd))
    n, ends = 0, []
    for i, (ts, data) in enumerate(packets):
        res = dec.decode(ts, data, pcl)
        if res is not None:
            n += len(res[1])
            ends.append(i)
    res = dec.finish(pcl)
    if res is not None:
        n += len(res[1])
    return n, ends


CPU = {"share": 1.0}  # CPU time / wall time of the last timed loop


def timed_loop(one_pass, seconds):
    """Run one_pass(r) (-> points) for whole passes until `seconds` have elapsed."""
    one_pass(-1)  # warm-up, untimed
    reps, points = 0, 0
    c0 = time.process_time()
    t0 = time.perf_counter()
    while True:
        points += one_pass(reps)
        reps += 1
        elapsed = time.perf_counter() - t0
        if elapsed >= seconds:
            CPU["share"] = (time.process_time() - c0) / elapsed
            return reps, points, elapsed


def bench_stream(vd, packets, seconds, pcl, as_list):
    feed = [(ts, list(d) if as_list else d) for ts, d in packets]
    span = capture_span(packets)
    state = {}

    def one_pass(r):
        if r <= 0:
            state["dec"] = vd.StreamDecoder(make_config(vd))
        dec = state["dec"]
        off = (r + 1) * span
        n = 0
        for ts, data in feed:
            res = dec.decode(ts + off, data, pcl)
            if res is not None:
                n += len(res[1])
        return n

    reps, points, elapsed = timed_loop(one_pass, seconds)
    t = time.perf_counter()
    res = state["dec"].finish(pcl)  # flush the last revolution; counted and timed
    if res is not None:
        points += len(res[1])
    elapsed += time.perf_counter() - t
    return reps, points, elapsed


def bench_scan(vd, packets, seconds, pcl, ends):
    frames, start = [], 0
    for end in ends + [len(packets) - 1]:
        if end < start:
            continue
        pv = vd.PacketVector()
        for ts, data in packets[start:end + 1]:
            pv.append(vd.VelodynePacket(ts, data))
        frames.append(pv)
        start = end + 1
    dec = vd.ScanDecoder(make_config(vd))

    def one_pass(_r):
        n = 0
        for pv in frames:
            n += len(dec.decode(pv, pcl)[1])
        return n

    return timed_loop(one_pass, seconds)


def bench_read_pcap(vd, path, seconds, pcl):
    def one_pass(_r):
        n = 0
        for _stamp, pts in vd.read_pcap(path, make_config(vd), as_pcl_structs=pcl):
            n += len(pts)
        return n

    return timed_loop(one_pass, seconds)


API_LABEL = {
    "stream": "StreamDecoder.decode(bytes)",
    "stream-list": "StreamDecoder.decode(list)",
    "scan": "ScanDecoder.decode(PacketVector)",
    "read_pcap": "read_pcap",
}


def main():
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("pcap", nargs="?", default=default_pcap(),
                   help="capture to decode (default: %(default)s)")
    p.add_argument("--json", action="store_true", help="print JSON instead of the text line")
    p.add_argument("--api", choices=APIS + ("all",), default="stream")
    p.add_argument("--seconds", type=float, default=3.0, help="minimum timed duration per API")
    p.add_argument("--pcl-structs", action="store_true", help="as_pcl_structs=True")
    p.add_argument("--port", type=int, help="only UDP payloads to this destination port")
    args = p.parse_args()

    vd = import_deps()
    version = library_version(vd)

    if not os.path.isfile(args.pcap):
        print("error: capture not found: %s" % args.pcap, file=sys.stderr)
        return 1
    try:
        packets = load_packets(args.pcap, args.port)
    except Exception as e:  # dpkt raises ValueError & co. on non-pcap input
        print("error: cannot read %s: %s" % (args.pcap, e), file=sys.stderr)
        return 1
    if not packets:
        print("error: no %d-byte UDP payloads in %s" % (PACKET_SIZE, args.pcap), file=sys.stderr)
        return 1
    modes = sorted({d[1204] for _, d in packets})
    mode = "/".join(RETURN_MODES.get(m, "0x%02x" % m) for m in modes)
    pcl = args.pcl_structs

    try:
        ref_points, ends = reference_pass(vd, packets, pcl)
    except Exception as e:  # e.g. product byte the VLP-16 config refuses
        print("error: velodyne-decoder failed on %s: %s" % (args.pcap, e), file=sys.stderr)
        return 1

    apis = APIS if args.api == "all" else (args.api,)
    for api in apis:
        if api == "stream":
            reps, points, elapsed = bench_stream(vd, packets, args.seconds, pcl, as_list=False)
        elif api == "stream-list":
            reps, points, elapsed = bench_stream(vd, packets, args.seconds, pcl, as_list=True)
        elif api == "scan":
            reps, points, elapsed = bench_scan(vd, packets, args.seconds, pcl, ends)
        else:
            reps, points, elapsed = bench_read_pcap(vd, args.pcap, args.seconds, pcl)
        if points != reps * ref_points:
            print("warning: %s decoded %d points in %d repeats, expected %d x %d"
                  % (api, points, reps, reps, ref_points), file=sys.stderr)
        if CPU["share"] < 0.9:
            print("warning: %s got only %.0f%% of a core (other processes running?); the figures "
                  "are low" % (api, 100 * CPU["share"]), file=sys.stderr)
        pkt_s = len(packets) * reps / elapsed
        pts_s = points / elapsed
        where = "from file" if api == "read_pcap" else "in memory"
        if args.json:
            print(json.dumps({
                "packets_per_s": round(pkt_s, 1), "points_per_s": round(pts_s, 1),
                "library": "velodyne-decoder", "version": version, "api": api,
                "as_pcl_structs": pcl, "capture": os.path.basename(args.pcap), "return_mode": mode,
                "packets": len(packets), "repeats": reps, "points_per_pass": ref_points,
                "seconds": round(elapsed, 3),
                "cpu_share": round(CPU["share"], 3)}))
        else:
            api_txt = "" if args.api == "stream" and not pcl else \
                ", %s%s" % (API_LABEL[api], ", as_pcl_structs" if pcl else "")
            print("velodyne-decoder %s: %.0f packets/s, %.1f M points/s (%s capture, %s%s, "
                  "%d packets x %d repeats)" % (version, pkt_s, pts_s / 1e6, mode, where, api_txt,
                                                len(packets), reps))
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
