"""SUMO drives over a grid of operating conditions (ODD), with a known degradation per condition.

    python -m examples.sim.odd_grid [--seed 1] [--runs 2] [--duration 25] [--out DIR]

The grid has the shape of the ODD study's environment table: `environment.weather` {cloudy,
rain, fog} x an intensity level {light, medium, heavy} x `environment.light` {day, sunset,
night}: 27 cells, `--runs` drives per cell (default 2, so 54 drives), all on the three-lane
highway. Each drive reports its weather's intensity as a number, `environment.intensity` 0-100
(cloud cover, precipitation or fog density, as CARLA's weather parameters), drawn from inside
its level's bin (light [0, 30], medium (30, 70], heavy (70, 100]: the study's bins, which
`casewatch odd --bins intensity=0,30,70,100:light,medium,heavy` recovers). Each drive is a
short SUMO run of the bundled highway following scenario, with a leader ahead of the ego and
background traffic, seen by two channels: `lidar` (all-round) and `camera` (forward only).
Every drive has its own seed, derived from (`--seed`, cell, run index), so SUMO's traffic, the
scripted vehicles' parameters, the intensity and every channel's noise differ between drives.

The conditions change the channels through one table, `CONDITION_EFFECTS` (docs/odd-grid.md):
per condition and channel, a factor on the position noise, a factor on the miss rate and a cap
on the sensing range, each a piecewise-linear function of the intensity that grows with it
(`light` and the interactions rain+night have their own entries). A drive is degraded when its
camera's noise factor reaches `DEGRADED_NOISE` or its range cap falls to `DEGRADED_RANGE_M`
(`is_degraded`): medium and heavy fog, heavy rain, medium rain at night. So a
detection-accuracy contract on the camera's gap to its leader fails in the degraded cells and
holds in the others, which `casewatch odd` is meant to recover from the streams alone.

Each stream's header carries the cell as a layered ODD description (`meta.odd`, PEGASUS-like
layers), what was done to the channels (`meta.odd_truth`: `degraded` and the applied
`channel_effects`), `meta.agent`, `meta.scenario` (the cell, e.g. `odd-fog-heavy-night`),
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
from examples.sim.simulate import SimulationError

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_OUT = ROOT / "examples" / "data" / "odd-grid"
DEFAULT_SEED = 1
DEFAULT_RUNS = 2
DEFAULT_DURATION = 20.0

#: The agent (driving stack) the drives are attributed to (`meta.agent`).
AGENT = "stack-A"

#: One road type: the grid varies the environment (the study's table); `road.type` is reported.
ROAD = "highway"
WEATHERS = ("cloudy", "rain", "fog")
LEVELS = ("light", "medium", "heavy")
LIGHTS = ("day", "sunset", "night")

#: The study's intensity bins (light [0, 30], medium (30, 70], heavy (70, 100]) and the range
#: each level's drives draw their intensity from: inside the bin, away from its edges, as a
#: simulator's weather presets would set it (a drive at 30.5 would be "medium" by the bins and
#: "light" by any eye).
BIN_EDGES = (0.0, 30.0, 70.0, 100.0)
LEVEL_DRAW: dict[str, tuple[float, float]] = {
    "light": (5.0, 25.0),
    "medium": (40.0, 60.0),
    "heavy": (80.0, 100.0),
}

#: A drive is degraded (its camera too poor for a detection-accuracy contract) when the camera's
#: noise factor is at least this, or its range cap at most DEGRADED_RANGE_M.
DEGRADED_NOISE = 6.0
DEGRADED_RANGE_M = 45.0

#: Lead gap [m] reported when there is no leader within this distance (casewatch's GAP_CAP,
#: monitor/situation.py).
GAP_CAP = 200.0

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
    LIDAR_STACK,
    name="lidar",
    seed=505,
    profile="GRID_LIDAR",
    p_miss=0.0005,
    miss_len=2.0,
    ghost_rate=0.01,
    prediction_points=6,
    prediction_step=0.5,
    plan_spacing=4.0,
    plan_lateral=0.05,
)
#: Forward camera, 120 degrees, 70 m; its position error grows less with range than
#: CAMERA_STACK's (0.08 m at 0 m, 0.12 m at 60 m per axis in good conditions) and its heading
#: error is half CAMERA_STACK's (0.01 rad, LIDAR_STACK's): casewatch counts a car as the leader
#: only if the chord to it runs along the mean of the two headings, so a heading error of
#: 0.06 rad (3 sigma at 0.02) tilts that line by 1.5 m at 50 m and drops a leader that is in
#: the lane.
GRID_CAMERA = replace(
    CAMERA_STACK,
    name="camera",
    seed=606,
    profile="GRID_CAMERA",
    pos_range_growth=0.5,
    yaw_sigma=0.01,
    p_miss=0.0005,
    miss_len=2.0,
    ghost_rate=0.02,
    prediction_points=6,
    prediction_step=0.5,
    plan_sampling="distance",
    plan_spacing=3.0,
    plan_lateral=0.05,
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
        return ChannelEffect(
            round(self.noise * other.noise, 4),
            round(self.miss * other.miss, 4),
            min(caps) if caps else None,
        )


NONE = ChannelEffect()

#: An effect that grows with the intensity: per field, (intensity, value) anchors, linear in
#: between (numpy.interp; flat beyond the ends). `range_m` None: no cap at any intensity.
Ramp = tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class EffectRamp:
    noise: Ramp = ((0.0, 1.0),)
    miss: Ramp = ((0.0, 1.0),)
    range_m: Ramp | None = None

    def at(self, intensity: float) -> ChannelEffect:
        def f(ramp: Ramp) -> float:
            xs, ys = zip(*ramp, strict=True)
            return round(float(np.interp(intensity, xs, ys)), 3)

        return ChannelEffect(
            f(self.noise), f(self.miss), None if self.range_m is None else f(self.range_m)
        )


#: The documented condition -> channel effect table (docs/odd-grid.md). Keys are condition
#: values (`environment.weather`, `environment.light`) or an interaction `"A+B"` that applies
#: on top of A's and B's own effects when both hold; each entry is a ramp over the weather's
#: intensity (0-100), steep between the levels' draw ranges (25-40, 60-80) and gentle inside
#: them. Channels not named are unaffected; `day` changes nothing, and neither does a
#: cloudy sky to the lidar.
CONDITION_EFFECTS: dict[str, dict[str, EffectRamp]] = {
    # overcast: a little less light for the camera
    "cloudy": {"camera": EffectRamp(noise=((0.0, 1.0), (100.0, 1.3)))},
    # droplets on the lens and spray: a noisier camera that misses more, steeply so in heavy
    # rain; lidar returns a little noisier
    "rain": {
        "camera": EffectRamp(
            noise=((0.0, 1.0), (25.0, 1.6), (40.0, 2.0), (60.0, 2.5), (80.0, 9.0), (100.0, 12.0)),
            miss=((0.0, 1.0), (100.0, 3.0)),
        ),
        "lidar": EffectRamp(noise=((0.0, 1.0), (100.0, 1.3)), miss=((0.0, 1.0), (100.0, 1.5))),
    },
    # visibility shrinks with the density: the camera sees nothing beyond its cap (70 m, its
    # own range, in light fog; 40-35 m medium; 25-20 m heavy), and what it sees is noisier;
    # the lidar loses a little precision and at most 10 m of range
    "fog": {
        "camera": EffectRamp(
            noise=((0.0, 1.0), (25.0, 2.0), (40.0, 8.0), (60.0, 10.0), (80.0, 14.0), (100.0, 18.0)),
            miss=((0.0, 1.0), (25.0, 1.5), (40.0, 4.0), (100.0, 6.0)),
            range_m=(
                (0.0, 200.0),
                (25.0, 70.0),
                (40.0, 40.0),
                (60.0, 35.0),
                (80.0, 25.0),
                (100.0, 20.0),
            ),
        ),
        "lidar": EffectRamp(
            noise=((0.0, 1.0), (100.0, 1.6)),
            miss=((0.0, 1.0), (100.0, 1.5)),
            range_m=((0.0, 200.0), (100.0, 70.0)),
        ),
    },
    # low sun into the lens: a slightly noisier camera
    "sunset": {"camera": EffectRamp(noise=((0.0, 1.4),), miss=((0.0, 1.2),))},
    # headlights only: a moderately noisier camera; the lidar does not care
    "night": {"camera": EffectRamp(noise=((0.0, 1.8),), miss=((0.0, 1.5),))},
    # wet road at night: headlight glare and reflections on top of rain and night, once the
    # road is more than damp
    "rain+night": {
        "camera": EffectRamp(
            noise=((0.0, 1.0), (25.0, 1.2), (40.0, 2.8), (100.0, 3.0)),
            miss=((0.0, 1.0), (40.0, 4.0)),
        )
    },
}


def level_of(intensity: float) -> str:
    """The study's bin of an intensity: light [0, 30], medium (30, 70], heavy (70, 100]."""
    if not BIN_EDGES[0] <= intensity <= BIN_EDGES[-1]:
        raise ValueError(f"intensity {intensity!r} outside [0, 100]")
    return (
        LEVELS[0]
        if intensity <= BIN_EDGES[1]
        else LEVELS[1]
        if intensity <= BIN_EDGES[2]
        else LEVELS[2]
    )


def effects(weather: str, intensity: float, light: str) -> dict[str, ChannelEffect]:
    """Per channel (every channel of CHANNELS), the combined effect of `weather` at
    `intensity` (0-100) and `light`: their own entries of CONDITION_EFFECTS and their
    interaction entry, if any."""
    if weather not in WEATHERS or light not in LIGHTS:
        raise ValueError(
            f"unknown condition {weather!r}/{light!r}; weather: {WEATHERS}, light: {LIGHTS}"
        )
    level_of(intensity)  # validates the intensity
    out = {c.name: NONE for c in CHANNELS}
    for key in (weather, light, f"{weather}+{light}"):
        for channel, ramp in CONDITION_EFFECTS.get(key, {}).items():
            out[channel] = out[channel].then(ramp.at(intensity))
    return out


def apply_effect(params: ChannelParams, eff: ChannelEffect) -> ChannelParams:
    """The channel's parameters under `eff` (a miss share stays below 0.5)."""
    rng = params.range_m if eff.range_m is None else min(params.range_m, eff.range_m)
    return replace(
        params,
        pos_sigma=params.pos_sigma * eff.noise,
        pos_white=params.pos_white * eff.noise,
        p_miss=min(0.5, params.p_miss * eff.miss),
        range_m=rng,
    )


def is_degraded(weather: str, intensity: float, light: str) -> bool:
    """The camera's noise factor at least DEGRADED_NOISE, or its range cap at most
    DEGRADED_RANGE_M."""
    cam = effects(weather, intensity, light)["camera"]
    return cam.noise >= DEGRADED_NOISE or (
        cam.range_m is not None and cam.range_m <= DEGRADED_RANGE_M
    )


def cell_name(weather: str, level: str, light: str) -> str:
    return f"odd-{weather}-{level}-{light}"


def cells() -> list[tuple[str, str, str]]:
    """The 27 cells (weather, intensity level, light) in a fixed order."""
    return [(w, lv, li) for w in WEATHERS for lv in LEVELS for li in LIGHTS]


def draw_intensity(level: str, seed: int) -> float:
    """A drive's intensity (0-100, one decimal): uniform over its level's LEVEL_DRAW range,
    from the drive's own seed."""
    lo, hi = LEVEL_DRAW[level]
    return round(float(np.random.default_rng([seed, 11]).uniform(lo, hi)), 1)


def odd_meta(weather: str, intensity: float, light: str) -> dict[str, dict[str, Any]]:
    """The drive's conditions as a layered ODD description (`meta.odd`): PEGASUS-like layers,
    road, infrastructure, temporary changes, traffic, environment, connectivity."""
    effects(weather, intensity, light)  # validates the environment
    return {
        "road": {"type": ROAD, "lanes": 3},
        "infrastructure": {"markings": "visible"},
        "temporary": {"roadworks": False},
        "traffic": {"density": "medium"},
        "environment": {"weather": weather, "intensity": intensity, "light": light},
        "connectivity": {"v2x": "none"},
    }


def odd_truth(weather: str, intensity: float, light: str) -> dict[str, Any]:
    """What was done to the channels (`meta.odd_truth`), for a checker to compare with."""
    eff = effects(weather, intensity, light)
    bad = is_degraded(weather, intensity, light)
    return {
        "degraded": bad,
        "degraded_channels": ["camera"] if bad else [],
        "channel_effects": {c: asdict(e) for c, e in eff.items()},
    }


def run_seed(seed: int, cell: int, run: int, attempt: int = 0) -> int:
    """The drive's own seed, from the grid seed, the cell's index and the run index (fits
    SUMO's 31-bit seed); `attempt` > 0 gives the next seeds to try when SUMO cannot insert the
    ego among the background traffic of the first."""
    key = [seed, cell, run] + ([attempt] if attempt else [])
    state = np.random.SeedSequence(key).generate_state(1)[0]
    return int(state) & 0x7FFFFFFF


#: Seeds tried per drive (run_seed's attempts) before the generator gives up.
ATTEMPTS = 3


def cell_scenario(
    weather: str,
    level: str,
    light: str,
    seed: int,
    duration: float = DEFAULT_DURATION,
) -> tuple[Scenario, float]:
    """One drive of a cell with its own `seed`, and its intensity: the intensity, the scripted
    vehicles' gaps, headways and speeds are drawn from the seed, SUMO and the channel noise are
    seeded with it; the channels carry the drive's effects."""
    rng = np.random.default_rng([seed, 7])
    intensity = draw_intensity(level, seed)
    eff = effects(weather, intensity, light)
    channels = tuple(apply_effect(c, eff[c.name]) for c in CHANNELS)
    name = cell_name(weather, level, light)
    tau = round(float(rng.uniform(1.0, 1.7)), 2)
    lead_pos = 400.0 + round(float(rng.uniform(45.0, 60.0)), 1)
    lead_speed = round(float(rng.uniform(21.0, 26.0)), 1)
    brake_at = round(float(rng.uniform(6.0, max(6.5, duration - 10.0))), 1)
    brake_to = round(float(rng.uniform(12.0, 18.0)), 1)
    sc = Scenario(
        name=name,
        description=(
            f"ODD grid cell {weather}/{level}/{light} (intensity {intensity:g}): three-lane "
            "highway, the ego follows a lead car (no lane changes) that slows down once and "
            "speeds up again, background traffic; channels lidar (all-round) and camera "
            "(forward)."
        ),
        network="highway",
        seed=seed,
        duration=duration,
        ego=VehicleSpec("ego", "ego", HW, 400.0, 1, lead_speed, lc_mode=512, max_speed=30.0),
        vehicles=(
            VehicleSpec(
                "lead", "lead", HW, lead_pos, 1, lead_speed, lc_mode=512, max_speed=lead_speed
            ),
        ),
        actions=(
            Action(0.5, "ego", "tau", tau),
            Action(brake_at, "lead", "slow_down", brake_to, 3.0),
            Action(brake_at + 5.0, "lead", "slow_down", lead_speed, 5.0),
        ),
        background=Background(initial=40, flow_per_hour=900.0),
        faults=(),
        channels=channels,
    )
    return sc, intensity


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


def odd_header(
    sc: Scenario, weather: str, intensity: float, light: str, run: int
) -> dict[str, Any]:
    """frames.header plus the ODD keys of `meta`."""
    head = header(sc)
    meta = head["header"]["meta"]
    meta.update(
        {
            "agent": AGENT,
            "run": run,
            "odd": odd_meta(weather, intensity, light),
            "odd_truth": odd_truth(weather, intensity, light),
        }
    )
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
    weather: str,
    level: str,
    light: str,
    run: int,
    seed: int,
    duration: float,
    out: Path,
    work: Path,
) -> dict[str, Any]:
    """Simulate one drive of a cell and write its stream; the index entry."""
    from examples.sim.simulate import run as simulate

    sc, intensity = cell_scenario(weather, level, light, seed, duration)
    gt = simulate(sc, work)
    path = out / f"{sc.name}-r{run}.jsonl.gz"
    count = write_stream(path, odd_header(sc, weather, intensity, light, run), odd_frames(sc, gt))
    return {
        "stream": path.name,
        "scenario": sc.name,
        "run": run,
        "seed": seed,
        "odd": {
            "road.type": ROAD,
            "environment.weather": weather,
            "environment.intensity": intensity,
            "environment.light": light,
        },
        "level": level,
        "degraded": is_degraded(weather, intensity, light),
        "duration": duration,
        "frames": count,
        "bytes": path.stat().st_size,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m examples.sim.odd_grid",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
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
        for ci, (weather, level, light) in enumerate(cells()):
            for r in range(args.runs):
                for attempt in range(ATTEMPTS):
                    seed = run_seed(args.seed, ci, r, attempt)
                    try:
                        entry = write_drive(
                            weather,
                            level,
                            light,
                            r,
                            seed,
                            args.duration,
                            args.out,
                            Path(tmp) / f"c{ci}r{r}a{attempt}",
                        )
                        break
                    except SimulationError as exc:
                        if attempt + 1 == ATTEMPTS:
                            raise
                        print(f"{exc}; trying the next seed", file=sys.stderr)
                index.append(entry)
                print(json.dumps(entry), flush=True)
    doc = {
        "generator": "python -m examples.sim.odd_grid",
        "seed": args.seed,
        "runs": args.runs,
        "duration": args.duration,
        "agent": AGENT,
        "drives": index,
    }
    (args.out / "index.json").write_text(json.dumps(doc, indent=1) + "\n")
    print_bundle(index, time.perf_counter() - start, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
