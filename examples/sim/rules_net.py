"""The road network of the traffic-rule drives (examples/sim/rules_drives.py, docs/rules-data.md).

One straight main road running east, with a one-lane road back west beside it and short cross
streets. Eastbound edges and junctions, in driving order:

| edge | from -> to | lanes | limit | lane boundaries (lane 0 = rightmost) |
| --- | --- | --- | --- | --- |
| `m1` | `W` -> `J1` | 2 | 13.89 m/s (50 km/h) | 0/1 broken |
| `m2` | `J1` -> `J2` | 2 | 8.33 m/s (30 km/h) | 0/1 broken |
| `m3` | `J2` -> `J3` | 2 | 13.89 m/s | 0/1 broken |
| `m4` | `J3` -> `J4` | 3 | 19.44 m/s (70 km/h) | 0/1 broken, 1/2 solid on lane 1's side |
| `m5` | `J4` -> `E` | 2 | 13.89 m/s | 0/1 double solid |

`J1` and `J2` are signalised (`traffic_light`), `J3` is an all-way stop (`allway_stop`: every
approach has a stop line), `J4` a plain priority junction where `m4`'s lanes 1 and 2 both feed
`m5`'s lane 1.

Lane markings are SUMO lane-change permissions (`changeLeft` / `changeRight` of the lane, the
vehicle classes allowed to change to the left / right neighbour; `authority` alone means "no
ordinary car"). Crossing the boundary between lanes a and b from lane a, the ego crosses:

- `broken` when SUMO lets a car change from a to b;
- `solid` when it does not, but does let a car change from b to a (a combined solid/broken
  line, solid on a's side);
- `double_solid` when it lets no car change either way.
"""

from __future__ import annotations

from itertools import pairwise
from pathlib import Path

from examples.sim.networks import _run, sumo_tool

#: x of each node on the main road [m].
NODES_X = {"W": 0.0, "J1": 250.0, "J2": 450.0, "J3": 650.0, "J4": 1000.0, "E": 1500.0}
MAIN = ("m1", "m2", "m3", "m4", "m5")
BACK = ("w5", "w4", "w3", "w2", "w1")  # westbound, one lane
SIGNALS = ("J1", "J2")
STOPS = ("J3",)
#: The class that may cross restricted markings (nobody in these drives drives as one except
#: the ego while it crosses a restricted marking on purpose, see rules_drives).
EXEMPT_CLASS = "authority"

_SPEED = {"m1": 13.89, "m2": 8.33, "m3": 13.89, "m4": 19.44, "m5": 13.89}
_LANES = {"m1": 2, "m2": 2, "m3": 2, "m4": 3, "m5": 2}
#: (edge, lane index) -> lane attributes (the markings)
_LANE_ATTRS = {
    ("m4", 1): 'changeLeft="authority"',  # 1 -> 2 forbidden, 2 -> 1 allowed: solid on 1's side
    ("m5", 0): 'changeLeft="authority"',  # 0 <-> 1 forbidden: double solid
    ("m5", 1): 'changeRight="authority"',
}


def build_rules_net(out_dir: Path) -> Path:
    """Write `rules.net.xml` (see the module docstring) and return its path."""
    out_dir.mkdir(parents=True, exist_ok=True)
    nod, edg, con = (out_dir / f"rules.{k}.xml" for k in ("nod", "edg", "con"))
    net = out_dir / "rules.net.xml"
    kinds = {
        "W": "priority",
        "J1": "traffic_light",
        "J2": "traffic_light",
        "J3": "allway_stop",
        "J4": "priority",
        "E": "priority",
    }
    nodes = [
        f'  <node id="{n}" x="{x:.1f}" y="0" type="{kinds[n]}"/>\n' for n, x in NODES_X.items()
    ]
    cross = []
    for j in ("J1", "J2", "J3"):
        x = NODES_X[j]
        nodes.append(f'  <node id="N{j[1]}" x="{x:.1f}" y="120" type="priority"/>\n')
        nodes.append(f'  <node id="S{j[1]}" x="{x:.1f}" y="-120" type="priority"/>\n')
        for a, b in ((f"N{j[1]}", j), (j, f"N{j[1]}"), (f"S{j[1]}", j), (j, f"S{j[1]}")):
            cross.append(f'  <edge id="{a}_{b}" from="{a}" to="{b}" numLanes="1" speed="13.89"/>\n')
    nod.write_text("<nodes>\n" + "".join(nodes) + "</nodes>\n")
    order = list(NODES_X)
    edges = []
    for i, e in enumerate(MAIN):
        lanes = "".join(
            f'\n    <lane index="{li}" {_LANE_ATTRS[(e, li)]}/>'
            for li in range(_LANES[e])
            if (e, li) in _LANE_ATTRS
        )
        edges.append(
            f'  <edge id="{e}" from="{order[i]}" to="{order[i + 1]}" '
            f'numLanes="{_LANES[e]}" speed="{_SPEED[e]}">{lanes}\n  </edge>\n'
        )
    for i, w in enumerate(BACK):
        a, b = order[len(order) - 1 - i], order[len(order) - 2 - i]
        edges.append(
            f'  <edge id="{w}" from="{a}" to="{b}" numLanes="1" '
            f'speed="{_SPEED[MAIN[len(MAIN) - 1 - i]]}"/>\n'
        )
    edg.write_text("<edges>\n" + "".join(edges) + "".join(cross) + "</edges>\n")
    cons = [
        f'  <connection from="{a}" to="{b}" fromLane="{i}" toLane="{i}"/>\n'
        for a, b in pairwise(MAIN)
        if a != "m3" and a != "m4"
        for i in range(2)
    ]
    cons += [f'  <connection from="m3" to="m4" fromLane="{i}" toLane="{i}"/>\n' for i in range(2)]
    cons += [
        '  <connection from="m4" to="m5" fromLane="0" toLane="0"/>\n',
        '  <connection from="m4" to="m5" fromLane="1" toLane="1"/>\n',
        '  <connection from="m4" to="m5" fromLane="2" toLane="1"/>\n',
    ]
    con.write_text("<connections>\n" + "".join(cons) + "</connections>\n")
    _run(
        [
            sumo_tool("netconvert"),
            "-n",
            str(nod),
            "-e",
            str(edg),
            "-x",
            str(con),
            "-o",
            str(net),
            "--no-turnarounds",
            "true",
            "--tls.default-type",
            "static",
            "--offset.disable-normalization",
            "true",
        ]
    )
    return net


__all__ = ["BACK", "EXEMPT_CLASS", "MAIN", "NODES_X", "SIGNALS", "STOPS", "build_rules_net"]
