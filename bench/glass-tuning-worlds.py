#!/usr/bin/env python3
"""Writes the worlds the glass parameters of issue 22 (item 2) were chosen on, into DIR.

Not the worlds the results are reported on (config/worlds/glass_*.toml and the scenes of
services/mapper/tests/panes.rs): a frameless partition through (5, 0) at ANGLE degrees off
square to the approach, in a room 8 m (or 12 m) wide, with one opening of WIDTH m centred at
S m along the partition (positive: the far end, at +y). Usage: glass-tuning-worlds.py DIR
"""
import math
import os
import sys

WORLDS = [  # name, angle, opening centre along the pane, width, half width of the room
    ("tune_partition_50_far", 50.0, 5.6, 1.1, 4.0),
    ("tune_storefront_door_right", 0.0, -2.8, 1.0, 6.0),
    ("tune_partition_20_middle", 20.0, 1.6, 1.0, 4.0),
    ("tune_partition_65_far", 65.0, 8.4, 1.2, 4.0),
]


def world(name, angle, centre, width, half):
    a = math.radians(angle)
    ux, uy = math.sin(a), math.cos(a)
    # the partition spans the room: from y = -half to y = +half along its line
    lo, hi = -half / uy, half / uy
    at = lambda s: (5.0 + s * ux, s * uy)
    out = [
        f'name = "{name}"',
        f'description = "issue 22 tuning world: a frameless partition {angle} degrees off square, '
        f'a {width} m opening {centre} m along it"',
        "start = [0.0, 0.0, 0.0]",
        "goal = [11.0, 0.0]",
        "time_limit_s = 150.0",
        "[ground]",
        "reflectivity = 15",
    ]
    for f, t in [((-1.5, -half), (14.0, -half)), ((-1.5, half), (14.0, half)),
                 ((-1.5, -half), (-1.5, half)), ((14.0, -half), (14.0, half))]:
        out += ["[[wall]]", f"from = [{f[0]}, {f[1]}]", f"to = [{t[0]}, {t[1]}]"]
    for s0, s1 in [(lo, centre - width / 2), (centre + width / 2, hi)]:
        if s1 - s0 > 0.05:
            p, q = at(s0), at(s1)
            out += ["[[glass]]", f"from = [{p[0]:.3f}, {p[1]:.3f}]",
                    f"to = [{q[0]:.3f}, {q[1]:.3f}]", "top = 2.4"]
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    d = sys.argv[1]
    os.makedirs(d, exist_ok=True)
    for w in WORLDS:
        with open(os.path.join(d, w[0] + ".toml"), "w") as f:
            f.write(world(*w))
