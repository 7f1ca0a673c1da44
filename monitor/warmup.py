"""Compile (or load from numba's cache) every metric kernel before real frames arrive.

Why: numba compiles a kernel on its first call, several seconds in all on a machine that has
never run casewatch, and loads it from its cache in a fraction of a second after that. A live
monitor should not spend that on its first real frame, and a batch run should not spend it once
per worker process: `casewatch run --jobs N` warms up in the parent before forking, so the
workers inherit compiled kernels.
"""

from __future__ import annotations

import math
from typing import Any

from monitor.engine import MetricEngine
from monitor.parse import parse_frame
from safety_case.model import MetricParams

_CHANNELS = ["a", "b"]


def _channel(t: float, offset: float, ids: tuple[Any, Any]) -> dict[str, Any]:
    """A car at 10 m/s with a 2 s plan, one vehicle ahead (predicted) and one crossing."""
    x = 10.0 * t + offset
    plan = [[0.1 * n, x + 1.0 * n, 0.0] for n in range(21)]
    ahead = [[0.1 * n, x + 12.0 + 0.8 * n, 0.0] for n in range(1, 31)]
    crossing = [[0.1 * n, x + 8.0, -6.0 + 0.5 * n] for n in range(1, 31)]
    return {
        "ego": {"x": x, "y": 0.0, "yaw": 0.0, "length": 4.5, "width": 1.9},
        "plan": plan,
        "objects": [
            {"id": ids[0], "x": x + 12.0, "y": 0.0, "length": 4.5, "width": 1.9,
             "prediction": ahead},
            {"id": ids[1], "x": x + 8.0, "y": -6.0, "yaw": math.pi / 2, "length": 4.5, "width": 1.9,
             "prediction": crossing},
        ],
    }  # fmt: skip


def warm_up(frames: int = 35) -> None:
    """Step a throw-away engine over `frames` synthetic frames of two channels: enough for
    every history (the comfort fits need 3 s of positions) and so every kernel. Channel b's object
    ids change every frame, so ompv's nearest matching (a channel that does not track) runs."""
    engine = MetricEngine(MetricParams(), _CHANNELS)
    for k in range(frames):
        t = round(0.1 * k, 1)
        a = _channel(t, 0.0, (1, 2))
        b = _channel(t, 0.3, (f"{k}-1", f"{k}-2"))
        d = {"t": t, "channels": {"a": a, "b": b}}
        engine.step(parse_frame(d, _CHANNELS, line=k + 1))
