"""Run a scenario in SUMO (through libsumo) and record the ground truth at every 0.1 s step.

Conventions (SUMO documentation, "TraCI/Vehicle Value Retrieval" and "FCD output"): a vehicle's
position is the centre of its FRONT bumper, and its angle is a navigational heading in degrees
(0 = north, clockwise). casewatch frames use the box centre and a yaw in radians counter-clockwise
from +x (east), so

    yaw    = radians(90 - angle)
    centre = front - (length / 2) * (cos(yaw), sin(yaw))

The state SUMO reports after the step that advances the clock to `T` is the state at `T - dt`
(the SSM device and FCD output stamp it so); `GroundTruth.times` uses that stamp, so it lines up
with the SSM output.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from examples.sim.networks import (
    GridSpec,
    HighwaySpec,
    MergeSpec,
    build_grid,
    build_highway,
    build_merge,
)
from examples.sim.scenarios import Scenario, VehicleSpec

STEP = 0.1
#: Seconds a lane change takes (SUMO's simple continuous lane-change model). SUMO's default, 0,
#: moves a vehicle across the lane (3.2 m) within one step: every lane change would read as a
#: teleport to a tracker (a missed prediction, a phantom conflict) and as tens of m/s^2 of
#: lateral acceleration in the comfort metrics.
LANE_CHANGE_DURATION = 3.0

#: vType definitions; lengths and widths are what the frames report as true footprints.
VTYPES = """
  <vType id="ego" vClass="passenger" length="4.6" width="1.9" accel="1.5" decel="3.0"
         emergencyDecel="9.0" carFollowModel="IDM" tau="1.5" minGap="2.5" sigma="0"
         speedFactor="1.0" lcOvertakeRight="1"/>
  <vType id="lead" vClass="passenger" length="4.5" width="1.8" accel="2.6" decel="7.5"
         apparentDecel="4.5" emergencyDecel="9.0"
         tau="1.4" minGap="2.5" sigma="0.2" speedFactor="1.0" lcOvertakeRight="1"/>
  <vType id="aggressive" vClass="passenger" length="4.7" width="1.85" accel="3.0" decel="5.0"
         tau="1.2" minGap="2.5" sigma="0.1" speedFactor="1.2" lcOvertakeRight="1"/>
  <vType id="car" vClass="passenger" length="4.5" width="1.8" accel="2.6" decel="4.5"
         tau="1.4" minGap="2.5" sigma="0.4" speedFactor="normc(1.0,0.1,0.8,1.2)"
         lcOvertakeRight="1"/>
  <vType id="truck" vClass="truck" length="12.0" width="2.5" accel="1.3" decel="4.0"
         tau="1.6" minGap="3.0" sigma="0.3" maxSpeed="25"/>
"""

SSM_MEASURES = "TTC DRAC PET SGAP TGAP"
SSM_THRESHOLDS = "3.0 3.0 2.0 100.0 10.0"  # SUMO defaults for TTC/DRAC/PET; gaps logged always


class SimulationError(RuntimeError):
    """SUMO failed or the scenario is inconsistent (e.g. the ego left the network early)."""


@dataclass
class GroundTruth:
    """Every vehicle's true state per step; arrays are (T, V) with NaN where absent."""

    scenario: str
    times: np.ndarray  # (T,)
    ids: list[str]
    cls: list[str]
    length: np.ndarray  # (V,)
    width: np.ndarray  # (V,)
    min_gap: np.ndarray  # (T, V) the car-following minGap in force (scripts change it)
    x: np.ndarray  # centre, world frame
    y: np.ndarray
    yaw: np.ndarray  # radians, counter-clockwise from +x
    speed: np.ndarray
    lane: np.ndarray  # (T, V) int index into lane_ids, -1 absent
    lane_pos: np.ndarray  # front-bumper position along the lane (m)
    lane_ids: list[str]
    speed_limit: np.ndarray  # (T,) the ego lane's speed limit
    sumo_leader: list[str | None]  # (T,) ego's leader from libsumo getLeader
    sumo_leader_gap: np.ndarray  # (T,) getLeader gap (front + minGap to leader's back), NaN
    ego_min_gap: np.ndarray  # (T,)
    ssm_file: Path
    ego_index: int = 0
    work_dir: Path = field(default_factory=Path)
    # (T,) the ego's lateral offset from its lane's centre line (m, SUMO's
    # getLateralLanePosition: positive to the left of the driving direction) and the width of
    # its lane (m); None for ground truths built by hand (the tests)
    ego_lateral: np.ndarray | None = None
    ego_lane_width: np.ndarray | None = None

    @property
    def present(self) -> np.ndarray:
        return ~np.isnan(self.x)


def sumo_to_centre(
    front_x: np.ndarray, front_y: np.ndarray, angle_deg: np.ndarray, length: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Convert SUMO front-bumper positions and navigational angles to centre and yaw (rad)."""
    yaw = np.radians(90.0 - np.asarray(angle_deg, dtype=float))
    yaw = (yaw + np.pi) % (2.0 * np.pi) - np.pi
    cx = np.asarray(front_x, dtype=float) - 0.5 * length * np.cos(yaw)
    cy = np.asarray(front_y, dtype=float) - 0.5 * length * np.sin(yaw)
    return cx, cy, yaw


def _vehicle_xml(v: VehicleSpec, route_id: str, ssm_file: Path | None) -> str:
    attrs = (
        f'id="{v.id}" type="{v.vtype}" route="{route_id}" depart="{v.depart:g}" '
        f'departPos="{v.depart_pos}" departLane="{v.depart_lane}" departSpeed="{v.depart_speed}"'
    )
    params = ""
    if ssm_file is not None:
        params = (
            '\n    <param key="has.ssm.device" value="true"/>'
            f'\n    <param key="device.ssm.measures" value="{SSM_MEASURES}"/>'
            f'\n    <param key="device.ssm.thresholds" value="{SSM_THRESHOLDS}"/>'
            '\n    <param key="device.ssm.range" value="60.0"/>'
            '\n    <param key="device.ssm.trajectories" value="true"/>'
            f'\n    <param key="device.ssm.file" value="{ssm_file}"/>\n  '
        )
    return f"  <vehicle {attrs}>{params}</vehicle>\n"


def _background_highway(sc: Scenario, rng: np.random.Generator, length: float) -> str:
    """Cars spread along the road at t=0 (avoiding the scripted vehicles' lane near them) and a
    flow entering at the western end; 10 % trucks, right lanes preferred by SUMO itself."""
    scripted = [(v.depart_pos, v.depart_lane) for v in (sc.ego, *sc.vehicles)]
    lines = []
    placed: list[tuple[float, int]] = []
    n = 0
    while n < sc.background.initial:
        pos = float(rng.uniform(20.0, length - 200.0))
        lane = int(rng.integers(0, 3))
        near_scripted = any(abs(pos - p) < 120.0 and lane == ln for p, ln in scripted)
        crowded = any(abs(pos - p) < 25.0 and lane == ln for p, ln in placed)
        if near_scripted or crowded:
            continue
        placed.append((pos, lane))
        vtype = "truck" if rng.random() < 0.1 else "car"
        speed = 20.0 if vtype == "truck" else float(rng.uniform(22.0, 30.0))
        lines.append((pos, lane, vtype, speed))
        n += 1
    out = []
    for k, (pos, lane, vtype, speed) in enumerate(sorted(lines)):
        out.append(
            f'  <vehicle id="bg{k}" type="{vtype}" route="hw" depart="0" departPos="{pos:.1f}" '
            f'departLane="{lane}" departSpeed="{speed:.1f}"/>\n'
        )
    if sc.background.flow_per_hour > 0:
        out.append(
            f'  <flow id="in" type="car" route="hw" begin="0" end="{sc.duration + 10}" '
            f'vehsPerHour="{sc.background.flow_per_hour}" departLane="best" '
            'departSpeed="desired"/>\n'
        )
    return "".join(out)


def _background_merge(sc: Scenario, rng: np.random.Generator, spec: MergeSpec) -> str:
    """Cars spread along the main road and the road after the merge at t=0 (as on the
    highway), a flow entering the main road at its western end and a flow on the ramp."""
    scripted = [
        (v.depart_pos, v.depart_lane) for v in (sc.ego, *sc.vehicles) if v.route[0] == "main"
    ]
    placed: list[tuple[str, float, int]] = []
    n = 0
    out_length = spec.length - spec.merge_x - spec.acc_length
    while n < sc.background.initial:
        on_main = rng.random() < spec.merge_x / (spec.merge_x + out_length)
        edge = "main" if on_main else "out"
        pos = float(rng.uniform(20.0, (spec.merge_x if on_main else out_length) - 50.0))
        lane = int(rng.integers(0, spec.lanes))
        near_scripted = on_main and any(abs(pos - p) < 120.0 and lane == ln for p, ln in scripted)
        crowded = any(e == edge and abs(pos - p) < 25.0 and lane == ln for e, p, ln in placed)
        if near_scripted or crowded:
            continue
        placed.append((edge, pos, lane))
        n += 1
    out = []
    for k, (edge, pos, lane) in enumerate(sorted(placed)):
        vtype = "truck" if rng.random() < 0.1 else "car"
        speed = 20.0 if vtype == "truck" else float(rng.uniform(22.0, 30.0))
        route = "through" if edge == "main" else "tail"
        out.append(
            f'  <vehicle id="bg{k}" type="{vtype}" route="{route}" depart="0" '
            f'departPos="{pos:.1f}" departLane="{lane}" departSpeed="{speed:.1f}"/>\n'
        )
    if sc.background.flow_per_hour > 0:
        out.append(
            f'  <flow id="in" type="car" route="through" begin="0" end="{sc.duration + 10}" '
            f'vehsPerHour="{sc.background.flow_per_hour}" departLane="best" '
            'departSpeed="desired"/>\n'
        )
        out.append(
            f'  <flow id="onramp" type="car" route="onramp" begin="0" '
            f'end="{sc.duration + 10}" vehsPerHour="{sc.background.flow_per_hour / 3:.0f}" '
            'departLane="best" departSpeed="desired"/>\n'
        )
    return "".join(out)


def _background_grid(sc: Scenario, rng: np.random.Generator, net_file: Path) -> str:
    """Random trips between grid edges, departing uniformly over the run (SUMO routes them)."""
    import sumolib

    net = sumolib.net.readNet(str(net_file))
    edges = sorted(e.getID() for e in net.getEdges() if not e.getID().startswith(":"))
    departs = np.sort(rng.uniform(0.0, sc.duration, sc.background.initial))
    out = []
    for k, dep in enumerate(departs):
        a, b = rng.choice(len(edges), size=2, replace=False)
        out.append(
            f'  <trip id="bg{k}" type="car" depart="{dep:.1f}" from="{edges[a]}" '
            f'to="{edges[b]}" departLane="best" departSpeed="max"/>\n'
        )
    return "".join(out)


def write_inputs(sc: Scenario, work_dir: Path) -> tuple[Path, Path, Path]:
    """Build the network and the routes file; return (net, routes, ssm output path)."""
    rng = np.random.default_rng(sc.seed)
    if sc.network == "highway":
        hw = HighwaySpec()
        net = build_highway(hw, work_dir)
        background = _background_highway(sc, rng, hw.length)
    elif sc.network == "merge":
        ms = MergeSpec()
        net = build_merge(ms, work_dir)
        background = _background_merge(sc, rng, ms)
    else:
        net = build_grid(GridSpec(), work_dir)
        background = _background_grid(sc, rng, net)
    ssm_file = work_dir / f"ssm_{sc.name}.xml"
    routes = [
        f'  <route id="r_{v.id}" edges="{" ".join(v.route)}"/>\n' for v in (sc.ego, *sc.vehicles)
    ]
    if sc.network == "highway":
        routes.append('  <route id="hw" edges="hw"/>\n')
    elif sc.network == "merge":
        routes.append('  <route id="through" edges="main acc out"/>\n')
        routes.append('  <route id="tail" edges="out"/>\n')
        routes.append('  <route id="onramp" edges="ramp acc out"/>\n')
    # scripted vehicles first, the ego last: at equal depart times SUMO inserts in file order,
    # and a lead placed before the ego must not be refused for violating the ego's safe gap
    vehicles = [_vehicle_xml(v, f"r_{v.id}", None) for v in sc.vehicles if v.depart == 0.0]
    vehicles.append(_vehicle_xml(sc.ego, f"r_{sc.ego.id}", ssm_file))
    # SUMO reads a route file in depart order: scripted vehicles departing later go after the
    # background (which departs at 0 on the highways)
    if sc.ego.depart != 0.0 or (sc.network == "grid" and any(v.depart for v in sc.vehicles)):
        raise SimulationError(
            f"scenario {sc.name}: only non-ego highway vehicles may depart after t=0"
        )
    late = [
        _vehicle_xml(v, f"r_{v.id}", None)
        for v in sorted(sc.vehicles, key=lambda v: v.depart)
        if v.depart > 0.0
    ]
    rou = work_dir / f"{sc.name}.rou.xml"
    rou.write_text(
        "<routes>\n"
        + VTYPES
        + "".join(routes)
        + "".join(vehicles)
        + background
        + "".join(late)
        + "</routes>\n"
    )
    return net, rou, ssm_file


def _apply(ls: object, kind: str, vid: str, value: float, duration: float) -> None:
    veh = ls.vehicle  # type: ignore[attr-defined]
    if kind == "tau":
        veh.setTau(vid, value)
    elif kind == "min_gap":
        veh.setMinGap(vid, value)
    elif kind == "max_speed":
        veh.setMaxSpeed(vid, value)
    elif kind == "lane":
        veh.changeLane(vid, int(value), duration)
    elif kind == "lc_mode":
        veh.setLaneChangeMode(vid, int(value))
    elif kind == "slow_down":
        veh.slowDown(vid, value, duration)
    else:  # pragma: no cover - ActionKind is a closed Literal
        raise SimulationError(f"unknown action kind '{kind}'")


def run(sc: Scenario, work_dir: Path | None = None, extra_time: float = 5.5) -> GroundTruth:
    """Simulate `sc` for its duration plus `extra_time` (so plans near the end are complete).

    Raises SimulationError when the ego is not on the network for the whole duration.
    """
    import libsumo as ls

    work = Path(work_dir) if work_dir is not None else Path(tempfile.mkdtemp(prefix="cwsim-"))
    work.mkdir(parents=True, exist_ok=True)
    net, rou, ssm_file = write_inputs(sc, work)
    ls.start(
        [
            "sumo",
            "-n",
            str(net),
            "-r",
            str(rou),
            "--step-length",
            f"{STEP}",
            "--seed",
            str(sc.seed),
            "--no-step-log",
            "true",
            "--no-warnings",
            "true",
            "--collision.action",
            "warn",
            "--time-to-teleport",
            "-1",
            "--default.action-step-length",
            f"{STEP}",
            "--lanechange.duration",
            f"{LANE_CHANGE_DURATION}",
        ]
    )
    ego = sc.ego.id
    steps = round((sc.duration + extra_time) / STEP) + 1
    index: dict[str, int] = {}
    ids: list[str] = []
    cls: list[str] = []
    lengths: list[float] = []
    widths: list[float] = []
    lane_index: dict[str, int] = {}
    rows: list[tuple[int, int, float, float, float, float, float, int, float]] = []
    times = np.zeros(steps)
    limit = np.full(steps, np.nan)
    leaders: list[str | None] = [None] * steps
    leader_gap = np.full(steps, np.nan)
    ego_min_gap = np.full(steps, np.nan)
    ego_lateral = np.full(steps, np.nan)
    ego_lane_width = np.full(steps, np.nan)
    actions = sorted(sc.actions, key=lambda a: a.time)
    next_action = 0
    configured: set[str] = set()
    try:
        for k in range(steps):
            ls.simulationStep()
            t = round(ls.simulation.getTime() - STEP, 3)
            times[k] = t
            live = ls.vehicle.getIDList()
            for v in (sc.ego, *sc.vehicles):
                if v.id in live and v.id not in configured:
                    if v.lc_mode is not None:
                        ls.vehicle.setLaneChangeMode(v.id, v.lc_mode)
                    if v.max_speed is not None:
                        ls.vehicle.setMaxSpeed(v.id, v.max_speed)
                    configured.add(v.id)
            while next_action < len(actions) and actions[next_action].time <= t + 1e-9:
                a = actions[next_action]
                if a.vehicle in live:
                    _apply(ls, a.kind, a.vehicle, a.value, a.duration)
                next_action += 1
            if ego not in live:
                if t <= sc.duration:
                    why = (
                        "SUMO refused to insert it (too close to the vehicle ahead for "
                        "its depart speed?)"
                        if t == 0.0
                        else "it left the network early"
                    )
                    raise SimulationError(
                        f"scenario {sc.name}: ego '{ego}' not on the network at t={t:.1f} s: {why}"
                    )
                times = times[:k]
                break
            for vid in live:
                j = index.get(vid)
                if j is None:
                    j = index[vid] = len(ids)
                    ids.append(vid)
                    vclass = ls.vehicle.getVehicleClass(vid)
                    cls.append("truck" if vclass == "truck" else "car")
                    lengths.append(ls.vehicle.getLength(vid))
                    widths.append(ls.vehicle.getWidth(vid))
                fx, fy = ls.vehicle.getPosition(vid)
                lane = ls.vehicle.getLaneID(vid)
                li = lane_index.setdefault(lane, len(lane_index))
                rows.append(
                    (
                        k,
                        j,
                        fx,
                        fy,
                        ls.vehicle.getAngle(vid),
                        ls.vehicle.getSpeed(vid),
                        ls.vehicle.getMinGap(vid),
                        li,
                        ls.vehicle.getLanePosition(vid),
                    )
                )
            lane = ls.vehicle.getLaneID(ego)
            limit[k] = ls.lane.getMaxSpeed(lane)
            lead = ls.vehicle.getLeader(ego, 100.0)
            if lead is not None and lead[0] != "":
                leaders[k] = lead[0]
                leader_gap[k] = lead[1]
            ego_min_gap[k] = ls.vehicle.getMinGap(ego)
            # queries only: they do not change the simulation
            ego_lateral[k] = ls.vehicle.getLateralLanePosition(ego)
            ego_lane_width[k] = ls.lane.getWidth(lane)
    finally:
        ls.close()

    n_t, n_v = len(times), len(ids)
    arr = np.array(rows, dtype=float)
    arr = arr[arr[:, 0] < n_t]
    ti, vi = arr[:, 0].astype(int), arr[:, 1].astype(int)

    def grid(col: int, fill: float = np.nan) -> np.ndarray:
        g = np.full((n_t, n_v), fill)
        g[ti, vi] = arr[:, col]
        return g

    length = np.array(lengths)
    fx, fy, ang = grid(2), grid(3), grid(4)
    cx, cy, yaw = sumo_to_centre(fx, fy, ang, length[None, :])
    lane_ids = [""] * len(lane_index)
    for name, i in lane_index.items():
        lane_ids[i] = name
    return GroundTruth(
        scenario=sc.name,
        times=times,
        ids=ids,
        cls=cls,
        length=length,
        width=np.array(widths),
        min_gap=grid(6),
        x=cx,
        y=cy,
        yaw=yaw,
        speed=grid(5),
        lane=grid(7, -1).astype(int),
        lane_pos=grid(8),
        lane_ids=lane_ids,
        speed_limit=limit[:n_t],
        sumo_leader=leaders[:n_t],
        sumo_leader_gap=leader_gap[:n_t],
        ego_min_gap=ego_min_gap[:n_t],
        ssm_file=ssm_file,
        ego_index=index[ego],
        work_dir=work,
        ego_lateral=ego_lateral[:n_t],
        ego_lane_width=ego_lane_width[:n_t],
    )


__all__ = ["STEP", "GroundTruth", "SimulationError", "run", "sumo_to_centre", "write_inputs"]
