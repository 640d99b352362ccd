#!/usr/bin/env python3
"""Print the point count of every frame velodyne-decoder (PyPI 3.1.0) decodes from a capture, one
per line. Exits non-zero if velodyne-decoder refuses a packet. Used by velodyne_decoder.rs."""
import sys

import dpkt
import velodyne_decoder as vd


def main(path):
    dec = vd.StreamDecoder(vd.Config(model=vd.Model.VLP16))
    with open(path, "rb") as f:
        for ts, buf in dpkt.pcap.Reader(f):
            udp = dpkt.ethernet.Ethernet(buf).data.data
            if len(udp.data) != 1206:
                continue
            res = dec.decode(float(ts), bytes(udp.data))
            if res is not None:
                print(len(res[1]))
    res = dec.finish()
    if res is not None:
        print(len(res[1]))


if __name__ == "__main__":
    main(sys.argv[1])
