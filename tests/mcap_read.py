"""Reads an MCAP file of `mimnav record` with PyPI's `mcap` package; prints one JSON object.

    python mcap_read.py FILE

Reads the file as a stream, record by record, so that a file whose writer was killed is read up
to its last complete chunk (`truncated` then says where the reading stopped); `summary` says
whether the file ends with a summary (a clean end), and `stats` holds the summary's message
counts per topic. Per topic: schema name and encoding, message encoding, the message count, the
sequence numbers, and for `foxglove.PointCloud` messages the point counts. `first_cloud`: the
first point cloud's sequence number and its x, y, z, intensity values (by the fields' offsets); `first_grid`, per topic of
`foxglove.Grid` messages: the first one's sequence number, column count, cell stride and data
(hex). `messages`, per topic of a `mimnav.*` schema (commands, goals, base states, verdicts,
scans): every message, decoded.
"""

import base64
import json
import struct
import sys

from mcap.reader import make_reader
from mcap.records import Channel, Footer, Message, Schema
from mcap.stream_reader import StreamReader

path = sys.argv[1]
schemas, channels, topics = {}, {}, {}
out = {"summary": False, "truncated": None, "stats": None, "topics": topics, "first_cloud": None, "first_grid": {}, "messages": {}}

with open(path, "rb") as f:
    try:
        for record in StreamReader(f).records:
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
                schema = schemas[record.schema_id]
                topics.setdefault(
                    record.topic,
                    {
                        "schema": schema.name,
                        "schema_encoding": schema.encoding,
                        "schema_title": json.loads(schema.data)["title"],
                        "message_encoding": record.message_encoding,
                        "count": 0,
                        "seqs": [],
                        "points": [],
                    },
                )
            elif isinstance(record, Message):
                channel = channels[record.channel_id]
                t = topics[channel.topic]
                message = json.loads(record.data)
                t["count"] += 1
                t["seqs"].append(record.sequence)
                if t["schema"] == "foxglove.PointCloud":
                    data = base64.b64decode(message["data"])
                    stride = message["point_stride"]
                    t["points"].append(len(data) // stride)
                    if out["first_cloud"] is None:
                        # x, y, z, intensity of every point, read by the fields' offsets
                        # (FLOAT32 is NumericType 7)
                        offsets = {f["name"]: f["offset"] for f in message["fields"] if f["type"] == 7}
                        values = []
                        for at in range(0, len(data), stride):
                            for name in ("x", "y", "z", "intensity"):
                                values.append(struct.unpack_from("<f", data, at + offsets[name])[0])
                        out["first_cloud"] = {"seq": record.sequence, "values": values}
                if t["schema"].startswith("mimnav."):
                    out["messages"].setdefault(channel.topic, []).append(message)
                if t["schema"] == "foxglove.Grid" and channel.topic not in out["first_grid"]:
                    out["first_grid"][channel.topic] = {
                        "seq": record.sequence,
                        "column_count": message["column_count"],
                        "cell_stride": message["cell_stride"],
                        "hex": base64.b64decode(message["data"]).hex(),
                    }
            elif isinstance(record, Footer):
                out["summary"] = record.summary_start != 0
    except Exception as e:  # a killed writer: the file ends inside a chunk
        out["truncated"] = "%s: %s" % (type(e).__name__, e)

if out["summary"]:
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
        counts = summary.statistics.channel_message_counts
        out["stats"] = {summary.channels[c].topic: n for c, n in counts.items()}

print(json.dumps(out))
