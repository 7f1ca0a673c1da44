"""SUMO drives that exercise the traffic rules, with ground-truth labels from SUMO's own state.

    python -m examples.sim.rules_drives [--seed 1] [--out examples/data/rules]

Three drivers (`AGENTS`: ego parameter sets and habits) x four scenarios (`SCENARIOS`) = 12
drives on the network of `examples/sim/rules_net.py`. Each frame carries the two channels of the
ODD grid (`lidar`, `camera`, with the scenario's weather and light effects) and a `world` entry
(docs/rules-data.md; `world.speed` is SUMO's ego speed) read from libsumo at that tick. The
labels (`<drive>.labels.jsonl`) come from the same per-tick SUMO state (speeds, lane limits,
signal states, stop lines, lane-change permissions, the vehicle's signal bits, SUMO's collision
detection), so `world` and labels agree by construction: both are the simulator's truth.

Writes `DIR/<scenario>-<agent>.jsonl.gz`, `.labels.jsonl` and `DIR/index.json`. Needs the
simulator extra (`pip install -e .[sim]`). Deterministic for a given SUMO version.
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from examples.sim.frames import print_bundle, write_jsonl, write_stream
from examples.sim.odd_grid import CHANNELS, ChannelEffect, apply_effect
from examples.sim.rules_net import EXEMPT_CLASS, MAIN, build_rules_net
from examples.sim.simulate import LANE_CHANGE_DURATION, STEP, GroundTruth, sumo_to_centre

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_OUT = ROOT / "examples" / "data" / "rules"
DEFAULT_SEED = 1
#: Seconds simulated past a drive's end, so the channels' plans near the end are complete.
EXTRA_TIME = 5.5

# --- rule ids (node ids of the traffic-rule case) and label definitions ------------------------
SPEEDING_LIGHT = "CSn_speeding_light"
SPEEDING_HEAVY = "CSn_speeding_heavy"
COLLISION = "CSn_collision"
COLLISION_VICTIM = "CSn_collision_victim"
RED_LIGHT = "CSn_red_light"
STOP_SIGN = "CSn_stop_sign"
SOLID_LINE = "CSn_solid_line"
DOUBLE_SOLID = "CSn_double_solid"
BROKEN_NO_INDICATOR = "CSn_broken_no_indicator"
BROKEN_WRONG_INDICATOR = "CSn_broken_wrong_indicator"
NO_HEADLIGHTS = "CSn_no_headlights"
NO_FOG_LIGHTS = "CSn_no_fog_lights"
RULES = (
    SPEEDING_LIGHT,
    SPEEDING_HEAVY,
    COLLISION,
    COLLISION_VICTIM,
    RED_LIGHT,
    STOP_SIGN,
    SOLID_LINE,
    DOUBLE_SOLID,
    BROKEN_NO_INDICATOR,
    BROKEN_WRONG_INDICATOR,
    NO_HEADLIGHTS,
    NO_FOG_LIGHTS,
)

HEAVY_FACTOR = 1.2  # speeding above limit * 1.2 is heavy
SPEEDING_MIN_DURATION = 0.5  # s, a speeding label's duration (its ticks times the period)
LIGHTS_MIN_DURATION = 0.5  # s, likewise for driving without low beam or fog lights
STANDSTILL = 0.1  # m/s
STOP_ZONE = 5.0  # m before a stop line where the standstill must happen
MOVING = 0.5  # m/s, "driving" for the headlight rule
LOOKAHEAD = 100.0  # m, signals and stop lines reported ahead
PAST_RANGE = 20.0  # m, a passed signal / stop line is still reported this far past it
MARKING_BAND = 0.5  # m, the marking is being crossed while the ego's centre is this close to it

# SUMO vehicle signal bits (TraCI getSignals)
BLINK_RIGHT, BLINK_LEFT, LOW_BEAM, FOG = 1, 2, 16, 32
SPEED_MODE_DEFAULT, SPEED_MODE_IGNORE_JUNCTION, SPEED_MODE_NONE = 31, 7, 0


@dataclass(frozen=True)
class Agent:
    """An ego parameter set and its habits.

    `speed_factor` multiplies the lane limit (SUMO vType speedFactor, no spread);
    `runs_late_yellow`: a light turning yellow when the ego is at most this many seconds away
    is run (SUMO speed mode 7: junction rules off until past the stop line; None: never);
    `stop_roll`: the speed [m/s] it rolls over a stop line at (None: stops as SUMO makes it);
    `illegal_changes`: performs the scenario's overtaking manoeuvres across restricted markings;
    `indicator`: uses the indicator when changing lanes; `inattentive`: drives into a stopped
    car ahead when a scenario sets that up; `lights(t, night, fog)`: (low beam, fog lights)."""

    name: str
    speed_factor: float
    accel: float
    decel: float
    tau: float
    runs_late_yellow: float | None
    stop_roll: float | None
    illegal_changes: bool
    indicator: bool
    inattentive: bool
    description: str
    wrong_way_right: bool = False  # indicates left while changing to the right

    def lights(self, t: float, night: bool, fog: bool) -> tuple[bool, bool]:
        if self.name == "careful":
            return (not night) or t >= 1.0, fog
        if self.name == "hurried":
            return True, fog and t >= 15.0
        forgot = night and (t < 8.0 or 24.0 <= t < 30.0)
        return not forgot, False


AGENTS: tuple[Agent, ...] = (
    Agent(
        "careful",
        0.92,
        2.0,
        3.0,
        1.5,
        None,
        None,
        False,
        True,
        False,
        "8 % below every limit, stops at yellow when it can, full stop at stop signs, legal "
        "lane changes with the indicator, lights on before driving off at night, fog lights "
        "in fog",
    ),
    Agent(
        "hurried",
        1.3,
        2.6,
        4.5,
        1.0,
        3.5,
        3.0,
        True,
        True,
        True,
        "30 % above the limit, runs a light that turns yellow less than 3.5 s ahead, rolls "
        "over stop lines at 3 m/s, overtakes across solid and double solid lines (indicator "
        "on; left when changing back to the right), drives into a stopped car when "
        "inattentive, fog lights only from 15 s",
        wrong_way_right=True,
    ),
    Agent(
        "sloppy",
        1.1,
        2.0,
        3.5,
        1.2,
        None,
        1.2,
        True,
        False,
        True,
        "10 % above the limit, creeps over stop lines at 1.2 m/s, changes lanes without "
        "the indicator (also across solid lines), drives into a stopped car when inattentive, "
        "forgets the low beam at night (0-8 s, 24-30 s) and never uses fog lights",
    ),
)
AGENT_BY_NAME = {a.name: a for a in AGENTS}


@dataclass(frozen=True)
class LightScript:
    """How a signal on the ego's route behaves relative to the ego (the signal is otherwise
    green). `near_miss`: yellow when the ego is `yellow_eta` s away, red the tick after its
    front crosses the stop line; else yellow at `yellow_eta`, red `yellow_time` s later, green
    again `red_time` s after that."""

    junction: str
    yellow_eta: float
    yellow_time: float = 2.5
    red_time: float = 10.0
    near_miss: bool = False


@dataclass(frozen=True)
class LaneChange:
    """At `pos` m along `edge`, change to lane `to`; `illegal` manoeuvres are only done by
    agents with `illegal_changes` (they cross a solid or double solid line)."""

    edge: str
    pos: float
    to: int
    illegal: bool = False


@dataclass(frozen=True)
class RulesScenario:
    name: str
    description: str
    depart_edge: str
    depart_pos: float
    depart_speed: float
    duration: float
    weather: str = "clear"
    light: str = "day"
    lights: tuple[LightScript, ...] = ()
    changes: tuple[LaneChange, ...] = ()
    rear_end: bool = False  # a follower hits the ego while it waits at J1; a car stops on m2
    oncoming_per_hour: float = 700.0
    hold_start: float = 0.0  # s the ego is held at standstill at the start


SCENARIOS: tuple[RulesScenario, ...] = (
    RulesScenario(
        "urban-lights",
        "Signals and speed limits: 50 km/h, a 30 km/h stretch, 50 km/h. J1 turns yellow 1 s "
        "before the ego reaches it and red just after it crossed; J2 turns yellow 3 s before, "
        "red 2.5 s later.",
        "m1",
        40.0,
        8.0,
        50.0,
        lights=(LightScript("J1", 1.0, near_miss=True), LightScript("J2", 3.0)),
    ),
    RulesScenario(
        "stop-and-merge",
        "The all-way stop J3, then the three-lane 70 km/h road: a lane change across a broken "
        "line and back, an overtaking manoeuvre across the solid line and back, and one "
        "across the double solid line after J4.",
        "m3",
        40.0,
        8.0,
        45.0,
        changes=(
            LaneChange("m4", 40.0, 1),
            LaneChange("m4", 110.0, 2, illegal=True),
            LaneChange("m4", 230.0, 1),
            LaneChange("m4", 300.0, 0),
            LaneChange("m5", 40.0, 1, illegal=True),
            LaneChange("m5", 200.0, 0, illegal=True),
        ),
    ),
    RulesScenario(
        "night-fog",
        "The urban stretch at night in fog: the ego starts at standstill (held 2 s); J1 turns "
        "red just after the ego crossed, J2 yellow 3 s before it.",
        "m1",
        20.0,
        0.0,
        40.0,
        weather="fog",
        light="night",
        lights=(LightScript("J1", 1.0, near_miss=True), LightScript("J2", 3.0)),
        hold_start=2.0,
    ),
    RulesScenario(
        "rear-end",
        "J1 turns red well ahead of the ego, which stops; a follower runs into it while it "
        "waits (the ego is the victim). After J1 a car stops on the 30 km/h stretch; an "
        "inattentive ego drives into it.",
        "m1",
        60.0,
        8.0,
        45.0,
        lights=(LightScript("J1", 6.0, yellow_time=3.0, red_time=9.0),),
        rear_end=True,
    ),
)
SCENARIO_BY_NAME = {s.name: s for s in SCENARIOS}

VTYPES = """
  <vType id="car" vClass="passenger" length="4.5" width="1.8" accel="2.6" decel="4.5"
         sigma="0.3" speedFactor="1.0" speedDev="0.05"/>
  <vType id="scripted" vClass="passenger" length="4.5" width="1.8" accel="2.6" decel="4.5"
         sigma="0" speedFactor="0.9" speedDev="0"/>
"""


def _ego_vtype(a: Agent) -> str:
    return (
        f'  <vType id="ego" vClass="passenger" length="4.6" width="1.9" accel="{a.accel}" '
        f'decel="{a.decel}" emergencyDecel="9.0" sigma="0" tau="{a.tau}" minGap="2.5" '
        f'speedFactor="{a.speed_factor}" speedDev="0"/>\n'
    )


def write_routes(sc: RulesScenario, agent: Agent, seed: int, work: Path) -> Path:
    rng = np.random.default_rng([seed, 11])
    i0 = MAIN.index(sc.depart_edge)
    route = " ".join(MAIN[i0:])
    lines = [
        "<routes>\n",
        VTYPES,
        _ego_vtype(agent),
        f'  <route id="ego_route" edges="{route}"/>\n',
        '  <route id="back" edges="w5 w4 w3 w2 w1"/>\n',
        '  <route id="back_mid" edges="w3 w2 w1"/>\n',
    ]
    vehicles = []
    if sc.rear_end:
        # the blocker stops on m2; the tailer follows the ego into J1's queue
        vehicles.append(
            (
                0.0,
                f'  <vehicle id="blocker" type="scripted" route="ego_route" '
                f'depart="0" departPos="{sc.depart_pos + 70:.1f}" departLane="0" '
                'departSpeed="8"/>\n',
            )
        )
        vehicles.append(
            (
                0.0,
                f'  <vehicle id="tailer" type="scripted" route="ego_route" '
                f'depart="0" departPos="{sc.depart_pos - 35:.1f}" '
                'departLane="0" departSpeed="8"/>\n',
            )
        )
    # oncoming traffic already on the road and a flow, seeded
    for k, pos in enumerate(sorted(rng.uniform(20.0, 180.0, 3))):
        vehicles.append(
            (
                0.0,
                f'  <vehicle id="on{k}" type="car" route="back_mid" depart="0" '
                f'departPos="{pos:.1f}" departSpeed="8"/>\n',
            )
        )
    vehicles.append(
        (
            0.0,
            f'  <vehicle id="ego" type="ego" route="ego_route" depart="0" '
            f'departPos="{sc.depart_pos}" departLane="0" '
            f'departSpeed="{sc.depart_speed}"/>\n',
        )
    )
    flow = (
        f'  <flow id="oncoming" type="car" route="back" begin="0" '
        f'end="{sc.duration + EXTRA_TIME}" vehsPerHour="{sc.oncoming_per_hour:g}" '
        'departSpeed="desired"/>\n'
    )
    rou = work / "rules.rou.xml"
    rou.write_text("".join(lines) + "".join(v for _, v in vehicles) + flow + "</routes>\n")
    return rou


# --- per-tick state ---------------------------------------------------------------------------


@dataclass
class Control:
    """A signal or stop line on the ego's route: the end of `edge` (its stop line)."""

    kind: str  # "traffic_light" | "stop"
    junction: str
    edge: str
    length: float
    crossed_at: float | None = None  # odometer reading when the front crossed the line
    link: int | None = None  # TLS link index of the ego's lane
    prev: tuple[float, float] | None = None  # (odometer, distance) at the last tick before


def _light_state(ch: str) -> str:
    if ch in "rRsu":
        return "red"
    if ch in "yY":
        return "yellow"
    if ch in "gG":
        return "green"
    return "off"


def _party(vclass: str) -> str:
    if vclass == "pedestrian":
        return "pedestrian"
    if vclass in ("bicycle", "moped", "motorcycle", "scooter"):
        return "two_wheeler"
    return "vehicle"


@dataclass
class Trace:
    """What the labels need per tick (the same values `world` reports)."""

    times: list[float] = field(default_factory=list)
    speed: list[float] = field(default_factory=list)
    limit: list[float] = field(default_factory=list)
    world: list[dict[str, Any]] = field(default_factory=list)
    # (tick, junction, state at the crossing tick, min speed within STOP_ZONE before it)
    tl_crossings: list[tuple[int, str, str]] = field(default_factory=list)
    stop_crossings: list[tuple[int, str, float]] = field(default_factory=list)
    marking_dir: list[str | None] = field(default_factory=list)


def simulate(sc: RulesScenario, agent: Agent, seed: int, work: Path) -> tuple[GroundTruth, Trace]:
    """Run one drive; the vehicles' true states (for the channels) and the ego's rule trace."""
    import libsumo as ls

    net = build_rules_net(work)
    rou = write_routes(sc, agent, seed, work)
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
            str(seed),
            "--no-step-log",
            "true",
            "--no-warnings",
            "true",
            "--collision.action",
            "warn",
            "--collision.check-junctions",
            "true",
            "--collision.mingap-factor",
            "0",
            "--time-to-teleport",
            "-1",
            "--default.action-step-length",
            f"{STEP}",
            "--lanechange.duration",
            f"{LANE_CHANGE_DURATION}",
        ]
    )
    night, fog = sc.light == "night", sc.weather == "fog"
    steps = round((sc.duration + EXTRA_TIME) / STEP) + 1
    tr = Trace()
    index: dict[str, int] = {}
    ids: list[str] = []
    cls: list[str] = []
    lengths: list[float] = []
    widths: list[float] = []
    rows: list[tuple[int, int, float, float, float, float]] = []
    scripts = {s.junction: s for s in sc.lights}
    light_phase: dict[str, tuple[str, float]] = {}  # junction -> (state, since)
    running: set[str] = set()  # junctions the ego runs (speed mode 7 until past)
    controls: list[Control] = []
    changes = [c for c in sc.changes if agent.illegal_changes or not c.illegal]
    pending_change: LaneChange | None = None
    change_right = False  # the pending change goes to a lane on the right
    route_length = 0.0
    depart_odo = sc.depart_pos
    prev_global: float | None = None
    stopped_since: float | None = None
    tail_state, block_state = "follow", "drive"
    block_resume_at = math.inf
    contacts_ever = False
    try:
        for k in range(steps):
            ls.simulationStep()
            t = round(ls.simulation.getTime() - STEP, 3)
            live = ls.vehicle.getIDList()
            if "ego" not in live:
                if t <= sc.duration:
                    raise RuntimeError(f"{sc.name}/{agent.name}: ego gone at t={t}")
                break
            if k == 0:
                ls.vehicle.setLaneChangeMode("ego", 512)
                for vid in ("blocker", "tailer"):
                    if vid in live:
                        ls.vehicle.setLaneChangeMode(vid, 512)
                for j in scripts:
                    n = len(ls.trafficlight.getRedYellowGreenState(j))
                    ls.trafficlight.setRedYellowGreenState(j, "G" * n)
                    light_phase[j] = ("G", 0.0)
                route = ls.vehicle.getRoute("ego")
                for e in route:
                    lane_len = ls.lane.getLength(f"{e}_0")
                    j = {"m1": "J1", "m2": "J2", "m3": "J3"}.get(e)
                    if j is not None:
                        kind = "stop" if j == "J3" else "traffic_light"
                        controls.append(Control(kind, j, e, lane_len))
                last = route[-1]
                route_length = (
                    sc.depart_pos
                    + ls.vehicle.getDistance("ego")
                    + ls.vehicle.getDrivingDistance("ego", last, ls.lane.getLength(f"{last}_0"))
                )
                if sc.hold_start > 0:
                    ls.vehicle.setSpeed("ego", 0.0)
            if sc.hold_start > 0 and abs(t - sc.hold_start) < 1e-6:
                ls.vehicle.setSpeed("ego", -1)
            odo = depart_odo + ls.vehicle.getDistance("ego")
            speed = ls.vehicle.getSpeed("ego")
            lane = ls.vehicle.getLaneID("ego")
            edge = ls.vehicle.getRoadID("ego")
            lpos = ls.vehicle.getLanePosition("ego")

            # --- signals and stop lines along the route ---------------------------------
            tls_next = {tl[0]: tl for tl in ls.vehicle.getNextTLS("ego")}
            for c in controls:
                if c.crossed_at is not None:
                    continue
                d = ls.vehicle.getDrivingDistance("ego", c.edge, c.length)
                if c.kind == "traffic_light" and c.junction in tls_next:
                    c.link = tls_next[c.junction][1]
                past = edge.startswith(f":{c.junction}_") or (
                    edge in MAIN and MAIN.index(edge) > MAIN.index(c.edge)
                )
                if d <= 0.0 or past:
                    c.crossed_at = (c.prev[0] + c.prev[1]) if c.prev else odo
                else:
                    c.prev = (odo, d)
            world: dict[str, Any] = {"speed_limit": round(ls.lane.getMaxSpeed(lane), 3)}
            for c in controls:
                dist = (
                    ls.vehicle.getDrivingDistance("ego", c.edge, c.length)
                    if c.crossed_at is None
                    else c.crossed_at - odo
                )
                if not (-PAST_RANGE <= dist <= LOOKAHEAD):
                    continue
                if c.kind == "traffic_light" and "traffic_light" not in world:
                    link = c.link if c.link is not None else 0
                    state = _light_state(ls.trafficlight.getRedYellowGreenState(c.junction)[link])
                    world["traffic_light"] = {"state": state, "distance": round(dist, 2)}
                elif c.kind == "stop" and "stop_sign" not in world:
                    world["stop_sign"] = {"distance": round(dist, 2)}

            # --- the ego's lane marking -------------------------------------------------
            marking, direction = None, None
            if not lane.startswith(":"):
                li = int(lane.rsplit("_", 1)[1])
                width = ls.lane.getWidth(lane)
                lat = ls.vehicle.getLateralLanePosition("ego")
                glob = li * width + lat
                moving = 0 if prev_global is None else np.sign(glob - prev_global)
                prev_global = glob
                n_lanes = ls.edge.getLaneNumber(edge)
                if li + 1 < n_lanes and width / 2 - lat <= MARKING_BAND and moving != 0:
                    a, b = (li, li + 1) if moving > 0 else (li + 1, li)
                elif li > 0 and lat + width / 2 <= MARKING_BAND and moving != 0:
                    a, b = (li - 1, li) if moving > 0 else (li, li - 1)
                else:
                    a = b = None
                if a is not None and b is not None:
                    marking = _marking(ls, edge, a, b)
                    direction = "left" if b > a else "right"
            else:
                prev_global = None
            if marking is not None:
                world["marking"] = marking
                world["crossing"] = direction
            tr.marking_dir.append(direction)

            # --- lights and indicator ---------------------------------------------------
            low, fogl = agent.lights(t, night, fog)
            want = (LOW_BEAM if low else 0) | (FOG if fogl else 0)
            changing = pending_change is not None
            if changing and not agent.indicator:
                ls.vehicle.setSignals("ego", want)  # every tick: suppresses the blinker
            elif changing and change_right and agent.wrong_way_right:
                ls.vehicle.setSignals("ego", want | BLINK_LEFT)  # every tick: the wrong blinker
            elif k == 0 or ls.vehicle.getSignals("ego") & (LOW_BEAM | FOG) != want:
                ls.vehicle.setSignals("ego", want)
            sig = ls.vehicle.getSignals("ego")
            indicator = "left" if sig & BLINK_LEFT else "right" if sig & BLINK_RIGHT else "off"
            world["indicator"] = indicator
            world["lights"] = {"low_beam": bool(sig & LOW_BEAM), "fog": bool(sig & FOG)}

            # --- contacts (SUMO collision detection, this step) ----------------------------
            contacts = []
            for col in ls.simulation.getCollisions():
                if "ego" not in (col.collider, col.victim):
                    continue
                other = col.victim if col.collider == "ego" else col.collider
                vclass = col.victimType if col.collider == "ego" else col.colliderType
                if other in live:  # the vehicle's class, not its vType id
                    vclass = ls.vehicle.getVehicleClass(other)
                contacts.append(
                    {"id": other, "with": _party(vclass), "ego_at_fault": col.collider == "ego"}
                )
            world["collisions"] = contacts
            world["route"] = {"progress": round(odo, 2), "length": round(route_length, 2)}

            # --- record -------------------------------------------------------------------
            if t <= sc.duration + 1e-9:
                tr.times.append(t)
                tr.speed.append(round(speed, 3))
                tr.limit.append(world["speed_limit"])
                tr.world.append(world)
            for vid in live:
                j = index.get(vid)
                if j is None:
                    j = index[vid] = len(ids)
                    ids.append(vid)
                    cls.append("truck" if ls.vehicle.getVehicleClass(vid) == "truck" else "car")
                    lengths.append(ls.vehicle.getLength(vid))
                    widths.append(ls.vehicle.getWidth(vid))
                fx, fy = ls.vehicle.getPosition(vid)
                rows.append((k, j, fx, fy, ls.vehicle.getAngle(vid), ls.vehicle.getSpeed(vid)))

            # --- the scripts act on this state for the next step ---------------------------
            for j, s in scripts.items():
                c = next(c for c in controls if c.junction == j)
                state, since = light_phase[j]
                n = len(ls.trafficlight.getRedYellowGreenState(j))
                eta = (
                    ls.vehicle.getDrivingDistance("ego", c.edge, c.length) / max(speed, 1.0)
                    if c.crossed_at is None
                    else -1.0
                )
                new = state
                if (
                    state == "G"
                    and c.crossed_at is None
                    and 0 <= eta <= s.yellow_eta
                    and since == 0.0
                ):
                    new = "y"
                    if agent.runs_late_yellow is not None and eta <= agent.runs_late_yellow:
                        running.add(j)
                        ls.vehicle.setSpeedMode("ego", SPEED_MODE_IGNORE_JUNCTION)
                elif state == "y" and (
                    (s.near_miss and c.crossed_at is not None)
                    or (not s.near_miss and t - since >= s.yellow_time)
                ):
                    new = "r"
                elif (
                    state == "r"
                    and t - since >= s.red_time
                    and not (
                        # the rear-end light stays red until the follower has hit the ego
                        sc.rear_end and tail_state in ("follow", "hitting") and t - since < 20.0
                    )
                ):
                    new = "g!"
                if new != state:
                    char = {"y": "y", "r": "r"}.get(new, "G")
                    ls.trafficlight.setRedYellowGreenState(j, char * n)
                    light_phase[j] = (new if new != "g!" else "G", t if new != "g!" else -1.0)
            for c in controls:
                if c.crossed_at is not None and c.junction in running:
                    running.discard(c.junction)
                    ls.vehicle.setSpeedMode("ego", SPEED_MODE_DEFAULT)
                    ls.vehicle.setSpeed("ego", -1)
                if (
                    c.kind == "stop"
                    and agent.stop_roll is not None
                    and c.crossed_at is None
                    and c.junction not in running
                ):
                    d = ls.vehicle.getDrivingDistance("ego", c.edge, c.length)
                    if 0 < d <= 25.0:
                        running.add(c.junction)
                        ls.vehicle.setSpeedMode("ego", SPEED_MODE_IGNORE_JUNCTION)
                        ls.vehicle.slowDown(
                            "ego", agent.stop_roll, max(0.5, (speed - agent.stop_roll) / 2.5)
                        )
                if c.kind == "stop" and c.junction in running and c.crossed_at is None:
                    d = ls.vehicle.getDrivingDistance("ego", c.edge, c.length)
                    if d <= 8.0:
                        ls.vehicle.setSpeed("ego", agent.stop_roll)

            # lane changes
            if (
                pending_change is None
                and changes
                and edge == changes[0].edge
                and lpos >= changes[0].pos
            ):
                pending_change = changes.pop(0)
                li = int(lane.rsplit("_", 1)[1])
                if pending_change.to == li:
                    pending_change = None
                else:
                    change_right = pending_change.to < li
                    if pending_change.illegal:
                        ls.vehicle.setVehicleClass("ego", EXEMPT_CLASS)
                    ls.vehicle.changeLane("ego", pending_change.to, 10.0)
            elif pending_change is not None and not lane.startswith(":"):
                li = int(lane.rsplit("_", 1)[1])
                if li == pending_change.to and abs(ls.vehicle.getLateralLanePosition("ego")) < 0.01:
                    if pending_change.illegal:
                        ls.vehicle.setVehicleClass("ego", "passenger")
                    pending_change = None
                    ls.vehicle.setSignals("ego", want)

            # rear-end scenario
            if sc.rear_end:
                stopped_since = (
                    (stopped_since if stopped_since is not None else t)
                    if speed < STANDSTILL
                    else None
                )
                ego_contact = any(not c_["ego_at_fault"] for c_ in contacts)
                if "tailer" in live:
                    if (
                        tail_state == "follow"
                        and edge == "m1"
                        and stopped_since is not None
                        and t - stopped_since >= 2.0
                    ):
                        ls.vehicle.setSpeedMode("tailer", SPEED_MODE_NONE)
                        ls.vehicle.setSpeed("tailer", 3.0)
                        tail_state = "hitting"
                    elif tail_state == "hitting" and ego_contact:
                        ls.vehicle.setSpeed("tailer", 0.0)
                        tail_state = "hit"
                    elif tail_state == "hit" and not ego_contact:
                        ls.vehicle.setSpeedMode("tailer", SPEED_MODE_DEFAULT)
                        ls.vehicle.setSpeed("tailer", -1)
                        tail_state = "done"
                if "blocker" in live:
                    bedge = ls.vehicle.getRoadID("blocker")
                    bpos = ls.vehicle.getLanePosition("blocker")
                    if block_state == "drive" and bedge == "m2" and bpos >= 110.0:
                        ls.vehicle.slowDown("blocker", 0.0, 2.0)
                        block_state = "stopping"
                    elif block_state == "stopping" and ls.vehicle.getSpeed("blocker") < 0.05:
                        ls.vehicle.setSpeed("blocker", 0.0)
                        block_state = "stopped"
                    lead = ls.vehicle.getLeader("ego", 50.0)
                    at_fault = any(c_["ego_at_fault"] for c_ in contacts)
                    if block_state == "stopped" and lead and lead[0] == "blocker":
                        if agent.inattentive and lead[1] < 12.0 and not contacts_ever:
                            ls.vehicle.setSpeedMode("ego", SPEED_MODE_NONE)
                            ls.vehicle.setSpeed("ego", max(speed, 3.0))
                            block_state = "hitting"
                        elif not agent.inattentive and speed < STANDSTILL:
                            block_resume_at = min(block_resume_at, t + 2.0)
                    if block_state == "hitting" and at_fault:
                        contacts_ever = True
                        ls.vehicle.setSpeed("ego", 0.0)
                        block_resume_at = t + 1.0
                        block_state = "stopped"
                    if t >= block_resume_at and block_state == "stopped":
                        ls.vehicle.setSpeed("blocker", -1)
                        block_state = "gone"
                    if block_state == "gone" and contacts_ever and not at_fault:
                        ls.vehicle.setSpeedMode("ego", SPEED_MODE_DEFAULT)
                        ls.vehicle.setSpeed("ego", -1)
                        contacts_ever = False
                        block_state = "done"
    finally:
        ls.close()

    n_t = max(r[0] for r in rows) + 1
    times = np.round(np.arange(n_t) * STEP, 3)
    arr = np.array(rows, dtype=float)
    ti, vi = arr[:, 0].astype(int), arr[:, 1].astype(int)

    def grid(col: int) -> np.ndarray:
        g = np.full((n_t, len(ids)), np.nan)
        g[ti, vi] = arr[:, col]
        return g

    length = np.array(lengths)
    cx, cy, yaw = sumo_to_centre(grid(2), grid(3), grid(4), length[None, :])
    gt = GroundTruth(
        scenario=sc.name,
        times=times,
        ids=ids,
        cls=cls,
        length=length,
        width=np.array(widths),
        min_gap=np.full((n_t, len(ids)), 2.5),
        x=cx,
        y=cy,
        yaw=yaw,
        speed=grid(5),
        lane=np.full((n_t, len(ids)), -1),
        lane_pos=np.full((n_t, len(ids)), np.nan),
        lane_ids=[],
        speed_limit=np.full(n_t, np.nan),
        sumo_leader=[None] * n_t,
        sumo_leader_gap=np.full(n_t, np.nan),
        ego_min_gap=np.full(n_t, 2.5),
        ssm_file=work / "none.xml",
        ego_index=index["ego"],
        work_dir=work,
    )
    return gt, tr


def _marking(ls: Any, edge: str, a: int, b: int) -> str:
    """The marking crossed from lane a to lane b of `edge` (see rules_net)."""

    def allowed(x: int, y: int) -> bool:
        direction = 1 if y > x else -1  # TraCI: 1 = to the left, -1 = to the right
        return "passenger" in ls.lane.getChangePermissions(f"{edge}_{x}", direction)

    fwd, back = allowed(a, b), allowed(b, a)
    if fwd:
        return "broken"
    return "solid" if back else "double_solid"


# --- labels -----------------------------------------------------------------------------------


def _runs(
    mask: list[bool], times: list[float], min_duration: float = 0.0
) -> list[tuple[float, float]]:
    out = []
    k = 0
    n = len(mask)
    while k < n:
        if mask[k]:
            j = k
            while j + 1 < n and mask[j + 1]:
                j += 1
            # casewatch's duration of a run of ticks: each tick lasts one period
            if times[j] - times[k] + STEP >= min_duration - 1e-9:
                out.append((times[k], times[j]))
            k = j + 1
        else:
            k += 1
    return out


def labels(tr: Trace, sc: RulesScenario) -> list[dict[str, Any]]:
    """Every rule's events from the trace (docs/rules-data.md, "Labels")."""
    t, v, lim, w = tr.times, tr.speed, tr.limit, tr.world
    out: list[dict[str, Any]] = []

    def add(rule: str, spans: list[tuple[float, float]]) -> None:
        out.extend({"hazard": rule, "start": a, "end": b} for a, b in spans)

    add(
        SPEEDING_LIGHT,
        _runs(
            [lim[k] < v[k] <= HEAVY_FACTOR * lim[k] for k in range(len(t))],
            t,
            SPEEDING_MIN_DURATION,
        ),
    )
    add(
        SPEEDING_HEAVY,
        _runs([v[k] > HEAVY_FACTOR * lim[k] for k in range(len(t))], t, SPEEDING_MIN_DURATION),
    )
    # contacts: one label per other party and uninterrupted run of ticks in contact
    for fault, rule in ((True, COLLISION), (False, COLLISION_VICTIM)):
        others = sorted({c["id"] for x in w for c in x["collisions"] if c["ego_at_fault"] is fault})
        for o in others:
            add(
                rule,
                _runs(
                    [
                        any(c["id"] == o and c["ego_at_fault"] is fault for c in x["collisions"])
                        for x in w
                    ],
                    t,
                ),
            )
    # signals and stop lines: the first tick whose distance is <= 0 is the crossing
    for key, rule in (("traffic_light", RED_LIGHT), ("stop_sign", STOP_SIGN)):
        prev = None
        for k, x in enumerate(w):
            cur = x.get(key)
            d = cur["distance"] if cur else None
            if d is not None and d <= 0 and prev is not None and prev > 0:
                if rule == RED_LIGHT and cur["state"] == "red":
                    add(rule, [(t[k], t[k])])
                if rule == STOP_SIGN:
                    zone = [
                        v[j]
                        for j in range(k)
                        if w[j].get(key) and 0 < w[j][key]["distance"] <= STOP_ZONE
                    ]
                    if not zone or min(zone) >= STANDSTILL:
                        add(rule, [(t[k], t[k])])
            prev = d
    add(SOLID_LINE, _runs([x.get("marking") == "solid" for x in w], t))
    add(DOUBLE_SOLID, _runs([x.get("marking") == "double_solid" for x in w], t))
    add(
        BROKEN_NO_INDICATOR,
        _runs([x.get("marking") == "broken" and x["indicator"] == "off" for x in w], t),
    )
    add(
        BROKEN_WRONG_INDICATOR,
        _runs(
            [
                x.get("marking") == "broken" and x["indicator"] not in ("off", x["crossing"])
                for x in w
            ],
            t,
        ),
    )
    if sc.light == "night":
        add(
            NO_HEADLIGHTS,
            _runs(
                [v[k] > MOVING and not w[k]["lights"]["low_beam"] for k in range(len(t))],
                t,
                LIGHTS_MIN_DURATION,
            ),
        )
    if sc.weather == "fog":
        add(
            NO_FOG_LIGHTS,
            _runs(
                [v[k] > MOVING and not w[k]["lights"]["fog"] for k in range(len(t))],
                t,
                LIGHTS_MIN_DURATION,
            ),
        )
    out.sort(key=lambda d: (d["start"], d["hazard"]))
    return out


# --- streams ----------------------------------------------------------------------------------


def drive_name(sc: RulesScenario, agent: Agent) -> str:
    return f"{sc.name}-{agent.name}"


def drive_seed(seed: int, si: int, ai: int) -> int:
    return int(np.random.SeedSequence([seed, si, ai]).generate_state(1)[0]) & 0x7FFFFFFF


def header(sc: RulesScenario, agent: Agent, seed: int, channels: tuple) -> dict[str, Any]:
    return {
        "header": {
            "format": "casewatch-frames",
            "version": 1,
            "channels": [c.name for c in channels],
            "period": STEP,
            "coverage": {c.name: c.coverage() for c in channels},
            "meta": {
                "scenario": sc.name,
                "agent": agent.name,
                "seed": seed,
                "description": sc.description,
                "agent_description": agent.description,
                "generator": "examples.sim.rules_drives (Eclipse SUMO via libsumo)",
                "network": "rules",
                "duration": sc.duration,
                "odd": {"environment": {"weather": sc.weather, "light": sc.light}},
                "channel_params": {c.name: c.meta() for c in channels},
            },
        }
    }


#: What the rule drives' conditions do to the channels: fog a noisy camera that sees 35 m and
#: a lidar that sees 70 m, night a noisier camera (the ODD grid's effects before it had
#: intensities, kept so the drives' channels do not change with the grid).
CONDITION_EFFECTS: dict[str, dict[str, ChannelEffect]] = {
    "fog": {
        "camera": ChannelEffect(noise=10.0, miss=5.0, range_m=35.0),
        "lidar": ChannelEffect(noise=1.5, miss=1.5, range_m=70.0),
    },
    "night": {"camera": ChannelEffect(noise=1.8, miss=1.5)},
}


def channel_effects(weather: str, light: str) -> dict[str, ChannelEffect]:
    """Per channel, the combined effect of `weather` and `light` (factors multiply, the
    shorter range cap wins)."""
    out = {c.name: ChannelEffect() for c in CHANNELS}
    for key in (weather, light):
        for channel, eff in CONDITION_EFFECTS.get(key, {}).items():
            out[channel] = out[channel].then(eff)
    return out


def write_drive(
    sc: RulesScenario, agent: Agent, seed: int, out: Path, work: Path
) -> dict[str, Any]:
    from examples.sim.channels import ChannelModel

    gt, tr = simulate(sc, agent, seed, work)
    eff = channel_effects(sc.weather, sc.light)
    channels = tuple(apply_effect(c, eff[c.name]) for c in CHANNELS)
    models = [ChannelModel(gt, p, (), seed) for p in channels]

    def rows():
        for k, tk in enumerate(tr.times):
            yield {
                "t": tk,
                "channels": {m.p.name: m.frame(k) for m in models},
                "world": {"speed": tr.speed[k], **tr.world[k]},
            }

    name = drive_name(sc, agent)
    path = out / f"{name}.jsonl.gz"
    count = write_stream(path, header(sc, agent, seed, channels), rows())
    lab = labels(tr, sc)
    write_jsonl(out / f"{name}.labels.jsonl", lab)
    counts = {r: sum(1 for x in lab if x["hazard"] == r) for r in RULES}
    return {
        "stream": path.name,
        "labels": f"{name}.labels.jsonl",
        "agent": agent.name,
        "scenario": sc.name,
        "seed": seed,
        "duration": sc.duration,
        "frames": count,
        "bytes": path.stat().st_size,
        "label_counts": counts,
        "odd": {"environment.weather": sc.weather, "environment.light": sc.light},
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m examples.sim.rules_drives",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--seed", type=int, default=DEFAULT_SEED)
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--only", default=None, help="one drive, <scenario>-<agent>")
    args = ap.parse_args(argv)
    try:
        import libsumo  # noqa: F401
    except ImportError:
        print("error: libsumo is not installed; run: pip install -e .[sim]", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    index = []
    with tempfile.TemporaryDirectory(prefix="cwrules-") as tmp:
        for si, sc in enumerate(SCENARIOS):
            for ai, agent in enumerate(AGENTS):
                if args.only and args.only != drive_name(sc, agent):
                    continue
                entry = write_drive(
                    sc, agent, drive_seed(args.seed, si, ai), args.out, Path(tmp) / f"s{si}a{ai}"
                )
                index.append(entry)
                print(
                    json.dumps(
                        {k: entry[k] for k in ("stream", "frames", "bytes")}
                        | {"labels": {r: n for r, n in entry["label_counts"].items() if n}}
                    ),
                    flush=True,
                )
    totals = {r: sum(e["label_counts"][r] for e in index) for r in RULES}
    if not args.only:
        doc = {
            "generator": "python -m examples.sim.rules_drives",
            "seed": args.seed,
            "agents": [a.name for a in AGENTS],
            "scenarios": [s.name for s in SCENARIOS],
            "label_totals": totals,
            "drives": index,
        }
        (args.out / "index.json").write_text(json.dumps(doc, indent=1) + "\n")
        # the road network, for the violation map of casewatch compare (--net)
        shutil.copy(build_rules_net(args.out / ".net-build"), args.out / "rules.net.xml")
        shutil.rmtree(args.out / ".net-build")
    for r, n in totals.items():
        print(f"{r:28s} {n:3d}")
    print_bundle(index, time.perf_counter() - start, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
