"""SUMO drives over a grid of operating conditions (ODD), with a known degradation per condition.

    python -m examples.sim.odd_grid [--seed 1] [--runs 4] [--duration 25] [--out DIR]

The grid is `road.type` {highway, urban} x `environment.weather` {clear, rain, fog} x
`environment.light` {day, night}: 12 cells, `--runs` drives per cell (default 4, so 48 drives).
Each drive is a short SUMO run of the same kind as the bundled reference scenarios (a highway
following scenario, or a tour of the signalised urban grid), with a leader ahead of the ego most
of the time and background traffic, seen by two channels: `lidar` (all-round) and `camera`
(forward only). Every drive has its own seed, derived from (`--seed`, cell, run index), so SUMO's
traffic, the scripted vehicles' parameters and every channel's noise differ between drives.

The conditions change the channels through one table, `CONDITION_EFFECTS` (docs/odd-grid.md):
per condition and channel, a factor on the position noise, a factor on the miss rate and a cap
on the sensing range. The camera is hit hard where `DEGRADED` says so (fog, and rain at night:
wet-road glare) and only mildly elsewhere; the lidar only a little anywhere. So a
detection-accuracy contract on the camera's gap to its leader fails in the degraded cells and
holds in the others, which `casewatch odd` is meant to recover from the streams alone.

Each stream's header carries the cell as a layered ODD description (`meta.odd`, PEGASUS-like
layers), what was done to the channels (`meta.odd_truth`: `degraded` and the applied
`channel_effects`), `meta.agent`, `meta.scenario` (the cell, e.g. `odd-highway-fog-night`),
`meta.run` and `meta.seed`. Each frame carries four ground-truth `signals` from SUMO:
`lane_offset`, `lane_width`, `gt_lead_gap` and `gt_lead_speed` (see `signals`).

Writes `DIR/<cell>-r<run>.jsonl.gz` and `DIR/index.json` (one entry per drive: file, cell,
conditions, degraded flag, seed, frames, bytes). Needs the simulator extra
(`pip install -e .[sim]`). Deterministic for a given SUMO version.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from examples.sim import labels as lab
from examples.sim.channels import CAMERA_STACK, LIDAR_STACK, ChannelModel, ChannelParams
from examples.sim.frames import header, print_bundle, write_stream
from examples.sim.scenarios import (
    HW,
    Action,
    Background,
    Scenario,
    VehicleSpec,
)

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_OUT = ROOT / "examples" / "data" / "odd-grid"
DEFAULT_SEED = 1
DEFAULT_RUNS = 4
DEFAULT_DURATION = 25.0

#: The agent (driving stack) the drives are attributed to (`meta.agent`).
AGENT = "stack-A"

ROAD_TYPES = ("highway", "urban")
WEATHERS = ("clear", "rain", "fog")
LIGHTS = ("day", "night")

#: The (weather, light) combinations whose camera is degraded enough to fail a detection-
#: accuracy contract (on either road type): fog by day and night, rain at night.
DEGRADED: frozenset[tuple[str, str]] = frozenset({("fog", "day"), ("fog", "night"),
                                                  ("rain", "night")})

#: Lead gap [m] reported when there is no leader within this distance (casewatch's GAP_CAP,
#: monitor/situation.py).
GAP_CAP = 200.0

#: The urban drives go straight east along the grid's middle row, through four signalised
#: junctions (red lights, cross traffic, queues), without turning: in a turn the forward camera
#: loses a leader that has turned out of its field of view, and the leader along the ego's lane
#: and the one along its planned path part for a moment. Those are effects of the geometry,
#: present in every weather; the grid varies weather and light only.
URBAN_STRAIGHT = ("A2B2", "B2C2", "C2D2", "D2E2")

# ---------------------------------------------------------------------------------------------
# Channels: the real-stack profiles, renamed, with predictions every 0.5 s (as LIDAR_STACK),
# plans resampled every 4 m (lidar, 5 s) and 3 m (camera, 3 s) along the path (a smaller
# bundle), and with few missed detections and ghosts in good conditions (a missed leader reads
# as a gap error of tens of metres for as long as it is missed, so the base miss rate decides
# the contract's violation rate in good conditions).
#
# The plans keep the lane centre to within 5 cm (plan_lateral 0.05 m instead of 0.2-0.3 m):
# casewatch looks for the leader along the plan extended straight along its last segment, and
# when the ego stops behind a queue the plan's last metres (or its only segment, creeping a few
# decimetres) carry the whole lateral offset, point 5-20 degrees sideways and miss a leader a
# few metres ahead. That would be a planning artefact in every weather; the grid is about
# detection. For the same reason plans are sampled by distance, not time (by time, the last
# points bunch up within centimetres at a stop).

#: All-round lidar, 80 m.
GRID_LIDAR = replace(
    LIDAR_STACK, name="lidar", seed=505, profile="GRID_LIDAR", p_miss=0.0005, miss_len=2.0,
    ghost_rate=0.01, prediction_points=6, prediction_step=0.5, plan_spacing=4.0,
    plan_lateral=0.05,
)
#: Forward camera, 120 degrees, 70 m; its position error grows less with range than
#: CAMERA_STACK's (0.08 m at 0 m, 0.12 m at 60 m per axis in good conditions) and its heading
#: error is half CAMERA_STACK's (0.01 rad, LIDAR_STACK's): casewatch counts a car as the leader
#: only if the chord to it runs along the mean of the two headings, so a heading error of
#: 0.06 rad (3 sigma at 0.02) tilts that line by 1.5 m at 50 m and drops a leader that is in
#: the lane.
GRID_CAMERA = replace(
    CAMERA_STACK, name="camera", seed=606, profile="GRID_CAMERA", pos_range_growth=0.5,
    yaw_sigma=0.01,
    p_miss=0.0005, miss_len=2.0, ghost_rate=0.02, prediction_points=6, prediction_step=0.5,
    plan_sampling="distance", plan_spacing=3.0, plan_lateral=0.05,
)
CHANNELS: tuple[ChannelParams, ...] = (GRID_LIDAR, GRID_CAMERA)


@dataclass(frozen=True)
class ChannelEffect:
    """What a condition does to one channel: `noise` multiplies the position error (the track
    error `pos_sigma` and the white noise `pos_white`), `miss` the share of missed ticks
    (`p_miss`), and `range_m` caps the sensing range (None: unchanged)."""

    noise: float = 1.0
    miss: float = 1.0
    range_m: float | None = None

    def then(self, other: ChannelEffect) -> ChannelEffect:
        """Both effects at once: factors multiply, the shorter range cap wins."""
        caps = [r for r in (self.range_m, other.range_m) if r is not None]
        return ChannelEffect(self.noise * other.noise, self.miss * other.miss,
                             min(caps) if caps else None)


NONE = ChannelEffect()

#: The documented condition -> channel effect table (docs/odd-grid.md). Keys are condition
#: values (`environment.weather`, `environment.light`) or an interaction `"A+B"` that applies
#: on top of A's and B's own effects when both hold. Channels not named are unaffected;
#: `clear` and `day` change nothing.
CONDITION_EFFECTS: dict[str, dict[str, ChannelEffect]] = {
    # droplets on the lens and spray: a noisier camera that misses more; lidar returns a
    # little noisier
    "rain": {"camera": ChannelEffect(noise=2.5, miss=1.5),
             "lidar": ChannelEffect(noise=1.2, miss=1.5)},
    # visibility about 35 m: the camera sees nothing beyond, and what it sees is very noisy;
    # the lidar loses a little range and precision
    "fog": {"camera": ChannelEffect(noise=10.0, miss=5.0, range_m=35.0),
            "lidar": ChannelEffect(noise=1.5, miss=1.5, range_m=70.0)},
    # headlights only: a moderately noisier camera; the lidar does not care
    "night": {"camera": ChannelEffect(noise=1.8, miss=1.5)},
    # wet road at night: headlight glare and reflections on top of rain and night
    "rain+night": {"camera": ChannelEffect(noise=3.0, miss=4.0)},
}


def effects(weather: str, light: str) -> dict[str, ChannelEffect]:
    """Per channel (every channel of CHANNELS), the combined effect of `weather` and `light`:
    their own entries of CONDITION_EFFECTS and their interaction entry, if any."""
    if weather not in WEATHERS or light not in LIGHTS:
        raise ValueError(f"unknown condition {weather!r}/{light!r}; "
                         f"weather: {WEATHERS}, light: {LIGHTS}")
    out = {c.name: NONE for c in CHANNELS}
    for key in (weather, light, f"{weather}+{light}"):
        for channel, eff in CONDITION_EFFECTS.get(key, {}).items():
            out[channel] = out[channel].then(eff)
    return out


def apply_effect(params: ChannelParams, eff: ChannelEffect) -> ChannelParams:
    """The channel's parameters under `eff` (a miss share stays below 0.5)."""
    rng = params.range_m if eff.range_m is None else min(params.range_m, eff.range_m)
    return replace(
        params, pos_sigma=params.pos_sigma * eff.noise, pos_white=params.pos_white * eff.noise,
        p_miss=min(0.5, params.p_miss * eff.miss), range_m=rng,
    )


def is_degraded(weather: str, light: str) -> bool:
    return (weather, light) in DEGRADED


def cell_name(road: str, weather: str, light: str) -> str:
    return f"odd-{road}-{weather}-{light}"


def cells() -> list[tuple[str, str, str]]:
    """The 12 cells (road, weather, light) in a fixed order."""
    return [(r, w, li) for r in ROAD_TYPES for w in WEATHERS for li in LIGHTS]


def odd_meta(road: str, weather: str, light: str) -> dict[str, dict[str, Any]]:
    """The cell as a layered ODD description (`meta.odd`): PEGASUS-like layers, road,
    infrastructure, temporary changes, traffic, environment, connectivity."""
    if road not in ROAD_TYPES:
        raise ValueError(f"unknown road type {road!r}; known: {ROAD_TYPES}")
    effects(weather, light)  # validates the environment
    return {
        "road": {"type": road, "lanes": 3 if road == "highway" else 2},
        "infrastructure": {"markings": "visible"},
        "temporary": {"roadworks": False},
        "traffic": {"density": "medium"},
        "environment": {"weather": weather, "light": light},
        "connectivity": {"v2x": "none"},
    }


def odd_truth(weather: str, light: str) -> dict[str, Any]:
    """What was done to the channels (`meta.odd_truth`), for a checker to compare with."""
    eff = effects(weather, light)
    return {
        "degraded": is_degraded(weather, light),
        "degraded_channels": ["camera"] if is_degraded(weather, light) else [],
        "channel_effects": {c: asdict(e) for c, e in eff.items()},
    }


def run_seed(seed: int, cell: int, run: int) -> int:
    """The drive's own seed, from the grid seed, the cell's index and the run index (fits
    SUMO's 31-bit seed)."""
    state = np.random.SeedSequence([seed, cell, run]).generate_state(1)[0]
    return int(state) & 0x7FFFFFFF


def cell_scenario(
    road: str, weather: str, light: str, seed: int, duration: float = DEFAULT_DURATION,
) -> Scenario:
    """One drive of a cell with its own `seed`: the scripted vehicles' gaps, headways and
    speeds are drawn from it, SUMO and the channel noise are seeded with it; the channels carry
    the cell's effects."""
    rng = np.random.default_rng([seed, 7])
    eff = effects(weather, light)
    channels = tuple(apply_effect(c, eff[c.name]) for c in CHANNELS)
    name = cell_name(road, weather, light)
    tau = round(float(rng.uniform(1.0, 1.7)), 2)
    if road == "highway":
        lead_pos = 400.0 + round(float(rng.uniform(45.0, 60.0)), 1)
        lead_speed = round(float(rng.uniform(21.0, 26.0)), 1)
        brake_at = round(float(rng.uniform(6.0, max(6.5, duration - 10.0))), 1)
        brake_to = round(float(rng.uniform(12.0, 18.0)), 1)
        return Scenario(
            name=name,
            description=(
                f"ODD grid cell {road}/{weather}/{light}: three-lane highway, the ego follows a "
                "lead car (no lane changes) that slows down once and speeds up again, "
                "background traffic; channels lidar (all-round) and camera (forward)."
            ),
            network="highway", seed=seed, duration=duration,
            ego=VehicleSpec("ego", "ego", HW, 400.0, 1, lead_speed, lc_mode=512,
                            max_speed=30.0),
            vehicles=(VehicleSpec("lead", "lead", HW, lead_pos, 1, lead_speed, lc_mode=512,
                                  max_speed=lead_speed),),
            actions=(
                Action(0.5, "ego", "tau", tau),
                Action(brake_at, "lead", "slow_down", brake_to, 3.0),
                Action(brake_at + 5.0, "lead", "slow_down", lead_speed, 5.0),
            ),
            background=Background(initial=60, flow_per_hour=900.0),
            faults=(), channels=channels,
        )
    lead_pos = 15.0 + round(float(rng.uniform(22.0, 40.0)), 1)
    return Scenario(
        name=name,
        description=(
            f"ODD grid cell {road}/{weather}/{light}: 5x5 signalised urban grid, the ego "
            "follows a lead car straight through signalised junctions (red lights, cross "
            "traffic), background traffic; channels lidar (all-round) and camera (forward)."
        ),
        network="grid", seed=seed, duration=duration,
        ego=VehicleSpec("ego", "ego", URBAN_STRAIGHT, 15.0, 0, 8.0, lc_mode=512,
                        max_speed=13.89),
        vehicles=(VehicleSpec("lead", "lead", URBAN_STRAIGHT, lead_pos, 0, 8.0, lc_mode=512,
                              max_speed=11.5),),
        actions=(Action(0.5, "ego", "tau", tau),),
        background=Background(initial=40),
        faults=(), channels=channels,
    )


def _num(v: float, digits: int = 3) -> float | None:
    v = float(v)
    return round(v, digits) if math.isfinite(v) else None


def signals(gt: Any) -> dict[str, np.ndarray]:
    """The four per-tick ground-truth signals (T,): `lane_offset` (the ego centre's signed
    lateral offset from its lane's centre line, m, positive to the left, SUMO's lateral lane
    position), `lane_width` (m), `gt_lead_gap` (bumper-to-bumper gap to the nearest leader in
    the ego's lane or its continuation, examples/sim/labels.py; GAP_CAP when there is none or
    it is farther) and `gt_lead_speed` (that leader's speed, m/s; 0 when none)."""
    fol = lab.following(gt)
    n = len(gt.times)
    lead = fol.lead
    has = (lead >= 0) & np.isfinite(fol.lead_gap) & (fol.lead_gap < GAP_CAP)
    speed = np.zeros(n)
    rows = np.flatnonzero(has)
    speed[rows] = gt.speed[rows, lead[rows]]
    return {
        "lane_offset": np.asarray(gt.ego_lateral, dtype=float),
        "lane_width": np.asarray(gt.ego_lane_width, dtype=float),
        "gt_lead_gap": np.where(has, fol.lead_gap, GAP_CAP),
        "gt_lead_speed": speed,
    }


def odd_header(sc: Scenario, road: str, weather: str, light: str, run: int) -> dict[str, Any]:
    """frames.header plus the ODD keys of `meta`."""
    head = header(sc)
    meta = head["header"]["meta"]
    meta.update({
        "agent": AGENT, "run": run, "odd": odd_meta(road, weather, light),
        "odd_truth": odd_truth(weather, light),
    })
    return head


def odd_frames(sc: Scenario, gt: Any) -> Iterator[dict[str, Any]]:
    """One frame per tick from t = 0 to the duration: both channels and the four signals."""
    models = [ChannelModel(gt, params, sc.faults, sc.seed) for params in sc.channels]
    sig = signals(gt)
    n = int(np.searchsorted(gt.times, sc.duration + 1e-9, side="right"))
    for k in range(n):
        yield {
            "t": round(float(gt.times[k]), 3),
            "channels": {m.p.name: m.frame(k) for m in models},
            "signals": {name: _num(v[k]) for name, v in sig.items()},
        }


def write_drive(
    road: str, weather: str, light: str, run: int, seed: int, duration: float, out: Path,
    work: Path,
) -> dict[str, Any]:
    """Simulate one drive of a cell and write its stream; the index entry."""
    from examples.sim.simulate import run as simulate

    sc = cell_scenario(road, weather, light, seed, duration)
    gt = simulate(sc, work)
    path = out / f"{sc.name}-r{run}.jsonl.gz"
    count = write_stream(path, odd_header(sc, road, weather, light, run), odd_frames(sc, gt))
    return {
        "stream": path.name, "scenario": sc.name, "run": run, "seed": seed,
        "odd": {"road.type": road, "environment.weather": weather,
                "environment.light": light},
        "degraded": is_degraded(weather, light), "duration": duration, "frames": count,
        "bytes": path.stat().st_size,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m examples.sim.odd_grid", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seed", type=int, default=DEFAULT_SEED)
    ap.add_argument("--runs", type=int, default=DEFAULT_RUNS, help="drives per cell")
    ap.add_argument("--duration", type=float, default=DEFAULT_DURATION, help="seconds")
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = ap.parse_args(argv)
    if args.runs < 1 or not args.duration > 0:
        print("error: --runs must be at least 1 and --duration positive", file=sys.stderr)
        return 2
    try:
        import libsumo  # noqa: F401
    except ImportError:
        print("error: libsumo is not installed; run: pip install -e .[sim]", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    for old in args.out.glob("odd-*.jsonl.gz"):
        old.unlink()  # a smaller grid must not leave drives of a larger one behind
    index = []
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="cwodd-") as tmp:
        for ci, (road, weather, light) in enumerate(cells()):
            for r in range(args.runs):
                seed = run_seed(args.seed, ci, r)
                entry = write_drive(road, weather, light, r, seed, args.duration, args.out,
                                    Path(tmp) / f"c{ci}r{r}")
                index.append(entry)
                print(json.dumps(entry), flush=True)
    doc = {"generator": "python -m examples.sim.odd_grid", "seed": args.seed,
           "runs": args.runs, "duration": args.duration, "agent": AGENT, "drives": index}
    (args.out / "index.json").write_text(json.dumps(doc, indent=1) + "\n")
    print_bundle(index, time.perf_counter() - start, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
