"""A remote host on PyPI's eclipse-zenoh, for tests/zenoh.rs (run in another network namespace).

Connects to mimnav-zenoh at ENDPOINT (peer mode, no multicast scouting), subscribes to the
TOPICS of ROBOT and prints one JSON line per sample received, decoded with
mimnav_client.decode_remote (which checks the header's count against the payload). Commands
on stdin, one a line, each answered with {"event": "sent", ...}:
  goal X Y TOL   a JSON goal on mimnav/ROBOT/goal
  stop           an empty message on mimnav/ROBOT/stop
  bad            a malformed goal and a goal with a tolerance out of range
  quit
usage: zenoh_peer.py ENDPOINT ROBOT TOPIC...
With ZENOH_PEER_TLS="DIR NAME" it connects with mutual TLS: DIR/ca.pem, DIR/NAME.pem and
DIR/NAME-key.pem.
"""

import json
import os
import sys
import threading

import zenoh

import mimnav_client as mc

lock = threading.Lock()


def say(**kv):
    with lock:
        print(json.dumps(kv), flush=True)


def on_sample(topic):
    def take(sample):
        enc = str(sample.encoding)
        try:
            m = mc.decode_remote(topic, sample.payload.to_bytes())
        except ValueError as e:
            say(event="bad", topic=topic, error=str(e), encoding=enc)
            return
        out = {"event": "sample", "topic": topic, "encoding": enc, "key": str(sample.key_expr),
               "bytes": len(sample.payload)}
        if topic == "lidar/points":
            out.update(seq=m.header.seq, point_count=m.header.point_count, items=len(m.items),
                       rings=len({p.ring for p in m.items}))
        elif topic == "map/plan":
            classes = {}
            for c in m.items:
                classes[c.class_] = classes.get(c.class_, 0) + 1
            out.update(seq=m.header.seq, cells=m.header.cells, items=len(m.items), classes=classes)
        elif topic == "cmd_vel":
            out.update(seq=m.items.seq, v=m.items.v, omega=m.items.omega, status=m.items.status)
        elif topic == "odom":
            out.update(seq=m.items.seq, x=m.items.x, y=m.items.y)
        say(**out)

    return take


def main():
    endpoint, robot, topics = sys.argv[1], sys.argv[2], sys.argv[3:]
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    conf.insert_json5("listen/endpoints", "[]")
    conf.insert_json5("scouting/multicast/enabled", "false")
    tls = os.environ.get("ZENOH_PEER_TLS")  # "DIR NAME": DIR/ca.pem, DIR/NAME.pem, DIR/NAME-key.pem
    if tls:
        d, name = tls.split()
        for key, value in (
            ("root_ca_certificate", f"{d}/ca.pem"),
            ("connect_certificate", f"{d}/{name}.pem"),
            ("connect_private_key", f"{d}/{name}-key.pem"),
        ):
            conf.insert_json5(f"transport/link/tls/{key}", json.dumps(value))
        conf.insert_json5("transport/link/tls/enable_mtls", "true")
    session = zenoh.open(conf)
    subs = [session.declare_subscriber(f"mimnav/{robot}/{t}", on_sample(t)) for t in topics]
    say(event="open", zid=str(session.info.zid()), subscribers=len(subs))
    goal_key, stop_key = f"mimnav/{robot}/goal", f"mimnav/{robot}/stop"
    for line in sys.stdin:
        cmd = line.split()
        if not cmd:
            continue
        if cmd[0] == "goal":
            x, y, tol = map(float, cmd[1:4])
            session.put(goal_key, mc.goal_json(x, y, tol), encoding=zenoh.Encoding.APPLICATION_JSON)
        elif cmd[0] == "stop":
            session.put(stop_key, b"")
        elif cmd[0] == "bad":
            session.put(goal_key, b'{"x": 1, "y":', encoding=zenoh.Encoding.APPLICATION_JSON)
            session.put(goal_key, mc.goal_json(1.0, 0.0, 50.0), encoding=zenoh.Encoding.APPLICATION_JSON)
        elif cmd[0] == "quit":
            break
        say(event="sent", what=cmd[0])
    for s in subs:
        s.undeclare()
    session.close()


if __name__ == "__main__":
    main()
