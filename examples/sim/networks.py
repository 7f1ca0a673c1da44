"""Small SUMO road networks, built by script so the data set can be regenerated anywhere.

Three networks: a straight multi-lane highway (plain XML through `netconvert`), a highway with
an on-ramp and an acceleration lane (plain XML with explicit lane connections), and an urban
grid with traffic-light junctions (`netgenerate --grid`). The binaries are looked up next to the
running Python first (the venv's `bin/`, where the `eclipse-sumo` wheel puts them), then on PATH.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path


class NetworkBuildError(RuntimeError):
    """A SUMO network tool is missing or failed; the message names the tool and its output."""


@dataclass(frozen=True)
class HighwaySpec:
    """A straight highway running east (+x); lane 0 is the rightmost lane (SUMO convention)."""

    length: float = 6000.0
    lanes: int = 3
    speed: float = 33.33


@dataclass(frozen=True)
class GridSpec:
    """A square grid of two-lane streets; every junction is signalised (static programs)."""

    junctions: int = 5
    block: float = 150.0
    lanes: int = 2
    speed: float = 13.89
    tls_cycle: int = 50  # s; short enough that a red light stops traffic for at most ~25 s
    # m/s^2: netgenerate limits the speed through a turn to this average lateral acceleration
    # (its default, 5.5, is a racing line; 2.5 is a comfortable urban turn)
    turn_lateral_acceleration: float = 2.5


@dataclass(frozen=True)
class MergeSpec:
    """A straight highway running east with an on-ramp joining from the right.

    Edges: `main` (west to the merge point, `lanes` lanes), `ramp` (one lane, joining at the
    merge point at a shallow angle), `acc` (`lanes` + 1 lanes for `acc_length` m: lane 0 is the
    acceleration lane the ramp feeds, the main lanes continue on lanes 1..), `out` (`lanes`
    lanes to the eastern end; the acceleration lane ends, so ramp traffic must change lanes
    within `acc_length`).
    """

    merge_x: float = 2000.0
    acc_length: float = 300.0
    length: float = 6000.0
    ramp_length: float = 300.0
    ramp_offset: float = 40.0  # m south of the main road where the ramp starts
    lanes: int = 3
    speed: float = 33.33
    ramp_speed: float = 25.0


def sumo_tool(name: str) -> str:
    """Path of a SUMO binary: the venv's bin directory first, then PATH."""
    candidate = Path(sys.executable).parent / name
    if candidate.exists():
        return str(candidate)
    found = shutil.which(name)
    if found is None:
        raise NetworkBuildError(
            f"SUMO tool '{name}' not found next to {sys.executable} nor on PATH; "
            "install the simulator extra: pip install -e .[sim]"
        )
    return found


def _run(cmd: list[str]) -> None:
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise NetworkBuildError(
            f"{Path(cmd[0]).name} failed (exit {proc.returncode}): {proc.stderr.strip()[-800:]}"
        )


def build_highway(spec: HighwaySpec, out_dir: Path) -> Path:
    """Write `highway.net.xml` (one edge `hw` from x=0 to x=length) and return its path.

    One long edge keeps every same-lane leader on the same lane id, so the geometric following
    relation used by the labels is unambiguous.
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    nodes = out_dir / "highway.nod.xml"
    edges = out_dir / "highway.edg.xml"
    net = out_dir / "highway.net.xml"
    nodes.write_text(
        "<nodes>\n"
        '  <node id="west" x="0" y="0" type="priority"/>\n'
        f'  <node id="east" x="{spec.length:.1f}" y="0" type="priority"/>\n'
        "</nodes>\n"
    )
    edges.write_text(
        "<edges>\n"
        f'  <edge id="hw" from="west" to="east" numLanes="{spec.lanes}" speed="{spec.speed}"/>\n'
        "</edges>\n"
    )
    _run(
        [
            sumo_tool("netconvert"),
            "-n",
            str(nodes),
            "-e",
            str(edges),
            "-o",
            str(net),
            "--no-turnarounds",
            "true",
        ]
    )
    return net


def build_grid(spec: GridSpec, out_dir: Path) -> Path:
    """Write `grid.net.xml` with traffic lights at every junction and return its path."""
    out_dir.mkdir(parents=True, exist_ok=True)
    net = out_dir / "grid.net.xml"
    _run(
        [
            sumo_tool("netgenerate"),
            "--grid",
            "--grid.number",
            str(spec.junctions),
            "--grid.length",
            f"{spec.block}",
            "--default.lanenumber",
            str(spec.lanes),
            "--default.speed",
            f"{spec.speed}",
            "--default-junction-type",
            "traffic_light",
            "--tls.default-type",
            "static",
            "--tls.cycle.time",
            str(spec.tls_cycle),
            "--no-turnarounds",
            "true",
            "--junctions.limit-turn-speed",
            f"{spec.turn_lateral_acceleration}",
            "-o",
            str(net),
        ]
    )
    return net


def build_merge(spec: MergeSpec, out_dir: Path) -> Path:
    """Write `merge.net.xml` (edges `main`, `ramp`, `acc`, `out`) and return its path."""
    out_dir.mkdir(parents=True, exist_ok=True)
    nodes = out_dir / "merge.nod.xml"
    edges = out_dir / "merge.edg.xml"
    cons = out_dir / "merge.con.xml"
    net = out_dir / "merge.net.xml"
    m1, m2 = spec.merge_x, spec.merge_x + spec.acc_length
    nodes.write_text(
        "<nodes>\n"
        '  <node id="west" x="0" y="0" type="priority"/>\n'
        f'  <node id="ramp_start" x="{m1 - spec.ramp_length:.1f}" y="{-spec.ramp_offset:.1f}" '
        'type="priority"/>\n'
        f'  <node id="merge" x="{m1:.1f}" y="0" type="priority"/>\n'
        f'  <node id="lane_drop" x="{m2:.1f}" y="0" type="priority"/>\n'
        f'  <node id="east" x="{spec.length:.1f}" y="0" type="priority"/>\n'
        "</nodes>\n"
    )
    n = spec.lanes
    edges.write_text(
        "<edges>\n"
        f'  <edge id="main" from="west" to="merge" numLanes="{n}" speed="{spec.speed}"/>\n'
        f'  <edge id="ramp" from="ramp_start" to="merge" numLanes="1" '
        f'speed="{spec.ramp_speed}"/>\n'
        f'  <edge id="acc" from="merge" to="lane_drop" numLanes="{n + 1}" speed="{spec.speed}"/>\n'
        f'  <edge id="out" from="lane_drop" to="east" numLanes="{n}" speed="{spec.speed}"/>\n'
        "</edges>\n"
    )
    lines = ['  <connection from="ramp" to="acc" fromLane="0" toLane="0"/>\n']
    lines += [
        f'  <connection from="main" to="acc" fromLane="{i}" toLane="{i + 1}"/>\n' for i in range(n)
    ]
    lines += [
        f'  <connection from="acc" to="out" fromLane="{i + 1}" toLane="{i}"/>\n' for i in range(n)
    ]
    cons.write_text("<connections>\n" + "".join(lines) + "</connections>\n")
    _run(
        [
            sumo_tool("netconvert"),
            "-n",
            str(nodes),
            "-e",
            str(edges),
            "-x",
            str(cons),
            "-o",
            str(net),
            "--no-turnarounds",
            "true",
        ]
    )
    return net
