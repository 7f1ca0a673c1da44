"""Compile (or load from numba's cache) every metric kernel before real frames arrive.

Why: numba compiles a kernel on its first call, several seconds in all on a machine that has
never run casewatch, and loads it from its cache in a fraction of a second after that. A live
monitor should not spend that on its first real frame, and a batch run should not spend it once
per worker process: `casewatch run --jobs N` warms up in the parent before forking, so the
workers inherit compiled kernels.
"""

from __future__ import annotations

import json
import math
from typing import Any

from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.fastparse import fast_frame
from casewatch.monitor.frames import Coverage, Frame
from casewatch.monitor.parse import parse_frame
from casewatch.safety_case.model import MetricParams

_CHANNELS = ["a", "b"]


def _channel(t: float, offset: float, ids: tuple[Any, Any], coarse: bool) -> dict[str, Any]:
    """A car at 10 m/s with a plan, one vehicle ahead (predicted) and one crossing.
    `coarse`: plan and predictions every 0.5 s (they take the interpolating resampler), else
    on the 0.1 s grid, predictions from dt = 0 (they take the short ways)."""
    x = 10.0 * t + offset
    step, first = (0.5, 1) if coarse else (0.1, 0)
    # fine plans 3.5 s (a window per point), coarse ones 2.5 s (shorter than comfort_span)
    n_plan, n_pred = (6, 6) if coarse else (36, 31)
    plan = [[step * n, x + 10.0 * step * n, 0.0] for n in range(n_plan)]
    ahead = [[step * n, x + 12.0 + 8.0 * step * n, 0.0] for n in range(first, n_pred)]
    crossing = [[step * n, x + 8.0, -6.0 + 5.0 * step * n] for n in range(first, n_pred)]
    return {
        "ego": {"x": x, "y": 0.0, "yaw": 0.0, "length": 4.5, "width": 1.9},
        "plan": plan,
        "objects": [
            {
                "id": ids[0],
                "x": x + 12.0,
                "y": 0.0,
                "length": 4.5,
                "width": 1.9,
                "prediction": ahead,
            },
            {
                "id": ids[1],
                "x": x + 8.0,
                "y": -6.0,
                "yaw": math.pi / 2,
                "length": 4.5,
                "width": 1.9,
                "prediction": crossing,
            },
        ],
    }


def warm_up(frames: int = 35) -> None:
    """Step a throw-away engine over `frames` synthetic frames of two channels: enough for
    every history (the comfort fits need 3 s of positions) and so every kernel. Channel b's object
    ids change every frame, so ompv's nearest matching (a channel that does not track) runs."""
    # channel b a forward camera: the coverage filter runs too; then the options that take
    # other kernels (plan smoothing, standing objects and plans, range-scaled tolerances:
    # the reference case's), so a case that sets them compiles nothing on its first frames
    for params in (MetricParams(), _OPTIONED):
        engine = MetricEngine(params, _CHANNELS, {"b": Coverage(fov_deg=120.0, range_m=70.0)})
        for k in range(frames):
            t = round(0.1 * k, 1)
            a = _channel(t, 0.0, (1, 2), coarse=False)
            b = _channel(t, 0.3, (f"{k}-1", f"{k}-2"), coarse=k % 2 == 1)
            if k % 5 == 4:  # b misses the crossing car: a's is unpaired (the lone-age kernel)
                b["objects"] = b["objects"][:1]
            d = {"t": t, "channels": {"a": a, "b": b}}
            engine.step(_read(d, k + 1))
    # a number of more than 19 significant digits: the compiled reader hands it to orjson and
    # takes its second entry point
    text = json.dumps({"t": 0.0, "channels": {"a": _channel(0.0, 0.0, (1, 2), False)}})
    fast_frame(text.replace('"x": 0.0', '"x": 0.1000000000000000000000001', 1), _CHANNELS, 1)


def _read(d: dict[str, Any], line: int) -> Frame:
    """The frame as a reader reads its JSON line, both ways, so that the compiled reader
    (`monitor.fastparse`) and the careful route's kernels (a line of another shape) compile
    here and not on a run's first line."""
    careful = parse_frame(d, _CHANNELS, line=line)
    frame = fast_frame(json.dumps(d), _CHANNELS, line)
    return frame if frame is not None else careful


#: Metric options that switch kernels on (examples/reference-case.yaml sets them all).
_OPTIONED = MetricParams(
    plan_smoothing=2.0,
    standing_motion=0.5,
    plan_standstill=1.0,
    ols_range_scale=50.0,
    ots_time_scale=1.0,
    ets_relative=1,
    ompv_lookback=0.5,
)
