"""Small frame builders for the monitor tests: JSON-shaped dicts, parsed like the reader does."""

from __future__ import annotations

from typing import Any

import numpy as np

from casewatch.monitor.frames import Frame
from casewatch.monitor.parse import parse_frame


def ego(
    x: float = 0.0,
    y: float = 0.0,
    yaw: float = 0.0,
    length: float = 4.0,
    width: float = 2.0,
    **extra: Any,
) -> dict[str, Any]:
    return {"x": x, "y": y, "yaw": yaw, "length": length, "width": width, **extra}


def obj(
    oid: str | int,
    x: float,
    y: float,
    yaw: float = 0.0,
    length: float = 4.0,
    width: float = 2.0,
    prediction: list[list[float]] | None = None,
    **extra: Any,
) -> dict[str, Any]:
    d: dict[str, Any] = {
        "id": oid,
        "x": x,
        "y": y,
        "yaw": yaw,
        "length": length,
        "width": width,
        **extra,
    }
    if prediction is not None:
        d["prediction"] = prediction
    return d


def channel(
    e: dict[str, Any],
    plan: list[list[float]] | None = None,
    objects: list[dict[str, Any]] | None = None,
) -> dict[str, Any]:
    return {"ego": e, "plan": plan or [], "objects": objects or []}


def frame_dict(
    t: float, channels: dict[str, Any], signals: dict[str, Any] | None = None
) -> dict[str, Any]:
    d: dict[str, Any] = {"t": t, "channels": channels}
    if signals is not None:
        d["signals"] = signals
    return d


def frame(t: float, channels: dict[str, Any], signals: dict[str, Any] | None = None) -> Frame:
    return parse_frame(frame_dict(t, channels, signals))


def straight_plan(
    x0: float, y0: float, vx: float, vy: float, n: int, step: float = 0.1
) -> list[list[float]]:
    """[dt, x, y] points of constant velocity, dt = 0, step, ... (rounded to avoid drift)."""
    dt = np.round(np.arange(n) * step, 10)
    return [[float(t), x0 + vx * float(t), y0 + vy * float(t)] for t in dt]
