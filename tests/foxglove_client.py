"""A Foxglove WebSocket client for the tests of mimnav-view, on PyPI's `websockets` (and PyPI's
`protobuf` to decode the messages with the schemas the server advertises, as Foxglove does).

It speaks Foxglove's WebSocket protocol, `foxglove.websocket.v1`, which the Foxglove SDK (0.30)
serves under the subprotocol name `foxglove.sdk.v1` (the same protocol renamed; the SDK refuses a
client offering only the old name with HTTP 400). It offers both names, the new first (as
Foxglove's app and Lichtblick do), reads `serverInfo` and
`advertise`, subscribes to the topics named, and decodes every binary `messageData` frame (opcode
1: subscription id u32, log time u64, then the message) with the channel's advertised encoding:
`protobuf` through a descriptor pool built from the channel's FileDescriptorSet, `json` as JSON.

Prints one JSON object a line on stdout:
  {"subprotocol": name}                      the one the server chose
  {"advertise": {topic: {"schemaName", "encoding"}}}
  {"subscribed": [topics]}
  {"topic": ..., "log_time": ..., ...}        one per message, a summary of its content
  {"done": true, "counts": {topic: n}}       at the end

  --stall: subscribe, then never read again for --seconds (the socket's buffers and the server's
           queue for this client fill up), then exit.

Usage: foxglove_client.py --url ws://127.0.0.1:8765 --topic /lidar/points --topic /map/plan
       [--count 5] [--seconds 30] [--stall]
"""

import argparse
import base64
import json
import struct
import sys
import time

from websockets.sync.client import connect
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]


def out(obj):
    print(json.dumps(obj), flush=True)


def message_class(channel):
    """The protobuf class of a channel from its advertised FileDescriptorSet."""
    fds = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    pending = list(fds.file)
    # dependencies first, whatever order the set lists them in
    while pending:
        left = []
        for f in pending:
            try:
                pool.Add(f)
            except Exception:
                left.append(f)
        if len(left) == len(pending):
            raise RuntimeError("cannot resolve the schema of " + channel["topic"])
        pending = left
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))


def stamp_ns(ts):
    return ts.seconds * 1_000_000_000 + ts.nanos


def summary(schema, msg):
    """What the Rust test compares with what the stack published."""
    if schema == "foxglove.PointCloud":
        stride, data = msg.point_stride, msg.data
        first = list(struct.unpack_from("<4f", data, 0)) if len(data) >= 16 else []
        return {
            "frame_id": msg.frame_id,
            "stamp_ns": stamp_ns(msg.timestamp),
            "point_stride": stride,
            "fields": [[f.name, f.offset, f.type] for f in msg.fields],
            "points": len(data) // stride if stride else 0,
            "first": first,
        }
    if schema == "foxglove.Grid":
        data = msg.data  # each access to the field makes a copy: once
        rows = len(data) // msg.row_stride if msg.row_stride else 0
        hist = {}
        for b in data[:: msg.cell_stride or 1]:
            hist[b] = hist.get(b, 0) + 1
        return {
            "frame_id": msg.frame_id,
            "stamp_ns": stamp_ns(msg.timestamp),
            "column_count": msg.column_count,
            "rows": rows,
            "cell_size": [msg.cell_size.x, msg.cell_size.y],
            "row_stride": msg.row_stride,
            "cell_stride": msg.cell_stride,
            "fields": [[f.name, f.offset, f.type] for f in msg.fields],
            "first_byte_hist": {str(k): v for k, v in sorted(hist.items())},
            "head": data[:64].hex(),
            "pose": [msg.pose.position.x, msg.pose.position.y],
        }
    if schema == "foxglove.FrameTransforms":
        return {"transforms": [[t.parent_frame_id, t.child_frame_id] for t in msg.transforms]}
    return {"fields": [f.name for f, _ in msg.ListFields()]}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--url", required=True)
    ap.add_argument("--topic", action="append", default=[])
    ap.add_argument("--count", type=int, default=5)
    ap.add_argument("--seconds", type=float, default=30.0)
    ap.add_argument("--stall", action="store_true")
    ap.add_argument("--rcvbuf", type=int, default=0,
                    help="the socket's receive buffer, bytes (small: a stalled client fills up fast)")
    ap.add_argument("--subprotocol", action="append", default=[],
                    help="offer only these (default: foxglove.sdk.v1, foxglove.websocket.v1)")
    a = ap.parse_args()

    # max_queue=1 in --stall: the library stops reading the socket once one frame waits
    offered = a.subprotocol or SUBPROTOCOLS
    sock = None
    if a.rcvbuf:
        import socket
        from urllib.parse import urlparse
        u = urlparse(a.url)
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, a.rcvbuf)
        sock.connect((u.hostname, u.port))
    try:
        ws = connect(
            a.url,
            sock=sock,
            subprotocols=offered,
            max_size=None,
            max_queue=1 if a.stall else 64,
            open_timeout=10,
            close_timeout=1,
        )
    except Exception as e:  # the handshake refused: say how, for the test
        out({"refused": str(e)})
        raise SystemExit(3)
    if ws.subprotocol not in offered:
        raise SystemExit(f"the server chose subprotocol {ws.subprotocol!r}")
    out({"subprotocol": ws.subprotocol})
    until = time.monotonic() + a.seconds
    channels = {}  # topic -> advertised channel
    while not all(t in channels for t in a.topic):
        left = until - time.monotonic()
        if left <= 0:
            raise SystemExit(f"not advertised within {a.seconds} s: {a.topic}, got {list(channels)}")
        m = ws.recv(timeout=left)
        if isinstance(m, str):
            op = json.loads(m)
            if op.get("op") == "advertise":
                for c in op["channels"]:
                    channels[c["topic"]] = c
    out({"advertise": {t: {"schemaName": c["schemaName"], "encoding": c["encoding"]}
                       for t, c in channels.items()}})
    subs = {}  # subscription id -> (topic, schema, decoder)
    for i, t in enumerate(a.topic, start=1):
        c = channels[t]
        decoder = message_class(c) if c["encoding"] == "protobuf" else None
        subs[i] = (t, c["schemaName"], decoder)
    ws.send(json.dumps({"op": "subscribe", "subscriptions":
                        [{"id": i, "channelId": channels[t]["id"]} for i, (t, _, _) in subs.items()]}))
    out({"subscribed": a.topic})

    if a.stall:
        time.sleep(max(0.0, until - time.monotonic()))
        out({"done": True, "stalled": True})
        sys.stdout.flush()
        # the socket may be too full for a closing handshake: just go
        import os
        os._exit(0)

    counts = {t: 0 for t in a.topic}
    while any(n < a.count for n in counts.values()):
        left = until - time.monotonic()
        if left <= 0:
            break
        try:
            m = ws.recv(timeout=left)
        except TimeoutError:
            break
        if isinstance(m, str):
            continue
        if m[0] != 1:
            continue
        sub_id, log_time = struct.unpack_from("<IQ", m, 1)
        if sub_id not in subs:
            continue
        topic, schema, decoder = subs[sub_id]
        payload = m[13:]
        if decoder is not None:
            msg = decoder.FromString(payload)
            line = summary(schema, msg)
        else:
            line = {"json": json.loads(payload)}
        line.update({"topic": topic, "schema": schema, "log_time": log_time})
        counts[topic] += 1
        out(line)
    out({"done": True, "counts": counts})
    ws.close()


if __name__ == "__main__":
    main()
